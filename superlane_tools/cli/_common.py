"""Shared CLI plumbing: conventions, error-to-exit-code mapping, consoles, the progress helper."""

from __future__ import annotations

import errno
import os
import re
import shlex
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any, NoReturn, get_args, get_origin

import typer
from rich.console import Console
from typer._click.exceptions import NoArgsIsHelpError, UsageError
from typer._click.globals import get_current_context
from typer.core import TyperArgument, TyperGroup

from superlane_tools.errors import ExitCode, MessageKind, SltError, message_line
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from typer._click.core import Command, Context

# soft_wrap: one message is one line on stderr (grep, log collectors), whatever the width.
err_console = Console(stderr=True, highlight=False, soft_wrap=True)
console = Console(highlight=False, soft_wrap=True)

EXIT_CODES_HELP = (
    "Exit codes: 0 ok, 1 error (bad input, nothing usable written), 2 usage, "
    "3 partial (outputs written but some input data was lost or skipped)."
)

CONTEXT_SETTINGS: dict[str, Any] = {"help_option_names": ["-h", "--help"], "show_default": True}
"""Root context settings; click hands them down to every command and group."""

PROGRESS_INTERVAL_ENV = "SLT_PROGRESS_INTERVAL_S"
"""Seconds between one-line progress reports when stderr is not a terminal (default 10)."""

_TYPE_METAVARS: dict[Any, str] = {Path: "PATH", str: "TEXT", int: "INTEGER", float: "NUMBER"}


def _metavar(param: Any) -> str | None:
    """Return the metavar a parameter shows in help: a word, not a Python type."""
    if param.param_type_name == "argument":
        return str(param.name).upper()  # the usage line adds "..." to a variadic argument
    many = getattr(param, "nargs", 1) == -1 or getattr(param, "multiple", False)
    descriptor = getattr(param, "type_descriptor", None)
    annotation = getattr(descriptor, "annotation", None)
    if get_origin(annotation) in (list, tuple) and get_args(annotation):
        annotation = get_args(annotation)[0]
    if annotation is bool:
        return None
    choices = getattr(descriptor, "choices", None) if getattr(descriptor, "is_choice", 0) else None
    if choices:
        word = "|".join(str(getattr(c, "value", c)) for c in choices)
    else:
        word = _TYPE_METAVARS.get(annotation, "VALUE")
    return f"{word}..." if many else word


def apply_conventions(command: Command) -> None:
    """Give ``command`` and everything under it the CLI conventions.

    Every command without a short help gets its help's whole first sentence (click would cut it
    to the terminal's width with "..." in the parent's command list). Every parameter without an
    explicit metavar gets a word (``RECORDING``, ``PATH``,
    ``PATH...``) instead of a Python type, and every ``--out`` option also answers to ``-o``.
    ``-h`` and shown defaults come from :data:`CONTEXT_SETTINGS`, which click hands down.
    Applied once to the root group (:class:`SltGroup`), so commands that other modules register
    follow the conventions without repeating them.
    """
    if not command.short_help and command.help:
        command.short_help = first_sentence(command.help)
    taken = {opt for param in command.params for opt in getattr(param, "opts", ())}
    for param in command.params:
        if param.metavar is None and not getattr(param, "is_flag", False):
            param.metavar = _metavar(param)
        if type(param) is TyperArgument:
            param.__class__ = _PlainArgument
        if param.param_type_name == "option" and "--out" in param.opts and "-o" not in taken:
            param.opts.append("-o")  # (-o taken by another option: the convention test says so)
    for sub in getattr(command, "commands", {}).values():
        apply_conventions(sub)


_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z(`'\"])")


def first_sentence(help_text: str) -> str:
    """Return the first sentence of a help text's first paragraph, on one line."""
    paragraph = " ".join(help_text.strip().split("\n\n", 1)[0].split()).removeprefix("\b ")
    return _SENTENCE_END.split(paragraph, 1)[0]


class _PlainArgument(TyperArgument):
    """A positional argument shown by its metavar alone (``INPUTS...``), no type after it."""

    def display_type_rich(self, ctx: Context) -> str | None:  # noqa: ARG002 (override)
        return None

    def _rich_display_name(self) -> str:
        return f"{self.metavar}..." if self.nargs != 1 else str(self.metavar)


class SltGroup(TyperGroup):
    """The root ``slt`` group: applies :func:`apply_conventions` to the whole command tree.

    It also renders every usage error of every command (unknown option, bad value, missing
    argument) as one ``slt: error:`` line with exit 2: the root's own arguments are parsed in
    :meth:`make_context`, every subcommand's inside :meth:`invoke`.
    """

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        apply_conventions(self)

    def make_context(
        self,
        info_name: str | None,
        args: list[str],
        parent: Context | None = None,
        **extra: Any,
    ) -> Context:
        """Parse the root's arguments; a usage error becomes one line."""
        try:
            return super().make_context(info_name, args, parent, **extra)
        except UsageError as err:
            raise _one_line(err) from err

    def invoke(self, ctx: Context) -> Any:
        """Run the subcommand; a usage error anywhere below becomes one line."""
        words = [*ctx._protected_args, *ctx.args]
        try:
            return super().invoke(ctx)
        except UsageError as err:
            raise _one_line(err, _command_path(self, words)) from err


def _command_path(group: Any, words: list[str]) -> str:
    """Return the subcommand names the words start with (``camera estimate``).

    For a usage error raised before the subcommand had a context (an option without its value).
    """
    path: list[str] = []
    command = group
    for word in words:
        sub = getattr(command, "commands", {}).get(word)
        if sub is None:
            break
        path.append(word)
        command = sub
    return " ".join(path)


def say(kind: MessageKind, text: str) -> None:
    """Print one message line ``slt: KIND: text`` to stderr (:func:`~.errors.message_line`)."""
    err_console.print(message_line(kind, text), markup=False)


def note(text: str) -> None:
    """Print one ``slt: note: ...`` line to stderr: a fact worth knowing, nothing was lost."""
    say("note", text)


def _subcommand_path(ctx: Context | None) -> str:
    """Return the names below the root of ``ctx``'s command path (``camera estimate``).

    The root's own name is left out whatever the program was called (``slt``, ``python -m
    ...``): only the subcommands' names are joined.
    """
    names: list[str] = []
    while ctx is not None and ctx.parent is not None:
        names.append(ctx.info_name or "")
        ctx = ctx.parent
    return " ".join(reversed(names))


def command_name() -> str:
    """Return the running command's name without ``slt`` (``camera estimate``; "" at the root)."""
    return _subcommand_path(_current_context())


def fail(message: str, code: ExitCode = ExitCode.ERROR) -> NoReturn:
    """Print one ``slt: error: ...`` line to stderr and exit with ``code``.

    A usage error (exit 2) names its command first, as click's own usage errors do:
    ``slt: error: reprocess: runs/x exists; pass --overwrite to replace it``.
    """
    name = command_name()
    if code == ExitCode.USAGE and name and not message.startswith(f"{name}: "):
        message = f"{name}: {message}"
    say("error", message)
    raise typer.Exit(int(code))


class OneLineUsageError(UsageError):
    """A click usage error shown as one ``slt: error:`` line (exit 2), not click's usage block."""

    path = ""
    """The subcommand's names when the error has no context (set by :func:`_one_line`)."""

    def show(self, file: IO[Any] | None = None) -> None:  # noqa: ARG002 (stderr console)
        """Print the error as one line naming the command and its ``-h``."""
        where = _subcommand_path(self.ctx) if self.ctx is not None else self.path
        hint = f" (see 'slt {where} -h')" if where else " (see 'slt -h')"
        text = self.format_message()
        say("error", f"{where}: {text}{hint}" if where else f"{text}{hint}")


def _one_line(err: UsageError, path: str = "") -> UsageError:
    """Return ``err`` as a :class:`OneLineUsageError` (help requested by no arguments stays).

    Args:
        err: Click's usage error.
        path: The subcommand's names when ``err`` carries no context.
    """
    if isinstance(err, (NoArgsIsHelpError, OneLineUsageError)):
        return err
    one = OneLineUsageError(err.format_message(), err.ctx)
    one.path = path
    one.exit_code = int(ExitCode.USAGE)
    return one


_DISK_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS}
"""OS errors of the output side: a full disk or quota, a file too large, a read-only mount."""


@contextmanager
def cli_errors() -> Iterator[None]:
    """Map ``SltError`` (and stray OS errors on files) to one line and an exit code."""
    try:
        yield
    except SltError as err:
        fail(str(err), err.exit_code)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        fail(f"{err.strerror}: {err.filename}", ExitCode.ERROR)
    except OSError as err:
        if err.errno not in _DISK_ERRNOS:
            raise
        if debug_enabled():
            raise
        where = f" {err.filename}" if err.filename else " the output"
        fail(f"cannot write{where}: {err.strerror or os.strerror(err.errno or 0)}")


def report_skipped(skipped: Sequence[Skipped]) -> ExitCode:
    """Print what was skipped or lost, one line per kind; return PARTIAL if anything was.

    Entries of one kind (``Skipped.what``) make one line: the kind, the number of items (or of
    entries), the first entry's detail and how many more there were, e.g.
    ``slt: skipped: bad NMEA checksum (11): line 3: ...; and 10 more``.
    """
    kinds: dict[str, list[Skipped]] = {}
    for item in skipped:
        kinds.setdefault(item.what, []).append(item)
    for what, items in kinds.items():
        n = sum(item.n_items for item in items) or (len(items) if len(items) > 1 else 0)
        count = f" ({n})" if n else ""
        more = f"; and {len(items) - 1} more" if len(items) > 1 else ""
        detail = " ".join(items[0].detail.split())
        say("skipped", f"{what}{count}: {detail}{more}")
    return ExitCode.PARTIAL if skipped else ExitCode.OK


def report_lost(skipped: Sequence[Skipped], nothing_read: bool, where: object) -> ExitCode:
    """Report what was lost (:func:`report_skipped`); ERROR when nothing at all was readable.

    A recording whose every message is lost (a ROS 2 bag without its ``messages`` table) gives
    its ``skipped:`` lines, then one error line, and exit 1: nothing usable came out.
    """
    code = report_skipped(skipped)
    if code != ExitCode.OK and nothing_read:
        say("error", f"{where}: no message is readable (what was lost is above)")
        return ExitCode.ERROR
    if isinstance(where, Path):  # a damaged recording: name the command that salvages it
        from superlane_tools.commands.options import recover_hint

        if hint := recover_hint(where, skipped):
            say("note", hint.replace("`", ""))
    return code


def check_camera(value: str | None) -> str | None:
    """Typer callback for ``--camera``: a profile or YAML that does not load is a usage error.

    ``auto`` (camera from the recording) passes through; any other value is loaded once here
    so that ``--camera nope`` exits 2 with click's usage message, before any work starts.
    """
    if value is None or value == "auto":
        return value
    from superlane_tools.commands.options import check_camera as load

    try:
        load(value)
    except SltError as err:
        raise typer.BadParameter(str(err)) from err
    return value


def check_model(value: str | None) -> str | None:
    """Typer callback for ``--model``: a model that is neither a file nor bundled exits 2."""
    if value is None:
        return value
    from superlane_tools.commands.options import check_model as resolve

    try:
        resolve(value)
    except SltError as err:
        raise typer.BadParameter(str(err)) from err
    return value


def model_option(help_text: str) -> Any:
    """Return the shared ``--model`` option: an ONNX file or a bundled model name (checked)."""
    return typer.Option("--model", help=help_text, callback=check_model)


def check_dbc_specs(values: list[Path] | None) -> list[Path] | None:
    """Typer callback for ``--dbc [BUS=]FILE``: a malformed spec or a missing file is a usage error.

    The file part of each value must be an existing file, so ``--dbc /missing.dbc`` exits 2
    before any work starts, with or without a ``BUS=`` prefix.
    """
    from superlane_tools.commands.options import dbc_spec_path

    for value in values or []:
        try:
            path = dbc_spec_path(str(value))
        except SltError as err:
            raise typer.BadParameter(str(err)) from err
        if not path.exists():  # what exists but is no DBC, the loader refuses (exit 1)
            raise typer.BadParameter(f"DBC file {str(path)!r} does not exist.")
    return values


def camera_option(help_text: str, metavar: str = "NAME|YAML") -> Any:
    """Return the shared ``--camera`` option: a bundled profile name or a camera YAML file.

    The value is loaded once while the command line is parsed (:func:`check_camera`), so a
    camera that does not load is a usage error (exit 2) before any work starts.
    """
    return typer.Option("--camera", metavar=metavar, help=help_text, callback=check_camera)


def debug_enabled() -> bool:
    """Return True when ``SLT_DEBUG`` asks for full tracebacks on internal errors."""
    return os.environ.get("SLT_DEBUG", "") not in {"", "0"}


def exit_with(code: ExitCode) -> None:
    """Exit the command with ``code`` unless it is OK."""
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


class ProgressLine:
    """Progress of one long step: a rich bar on a terminal, periodic lines on stderr otherwise.

    On a pipe, in cron or under a log collector there is no bar to redraw, so every
    ``SLT_PROGRESS_INTERVAL_S`` seconds (default 10) one line such as
    ``slt: progress: reprocess 120/240 (50%) 11.3/s 10 s`` goes to stderr. Use it through
    :func:`progress`.
    """

    def __init__(self, label: str, total: int | None, unit: str) -> None:
        self.label = label
        self.total = total
        self.done = 0
        self.unit = unit
        self.note = ""
        self._start = time.perf_counter()
        self._phase_start = self._start
        self._last_line = self._start
        self._interval = float(os.environ.get(PROGRESS_INTERVAL_ENV, "10"))
        self._bar: Any = None
        self._task: Any = None

    def __enter__(self) -> ProgressLine:
        if err_console.is_terminal:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self._bar = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.fields[count]}"),  # "12/240", or nothing while unknown
                TextColumn("{task.fields[note]}"),
                TimeElapsedColumn(),
                console=err_console,
                transient=True,
            )
            self._bar.__enter__()
            self._task = self._bar.add_task(self.label, total=self.total, note="", count="")
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._bar is not None:
            self._bar.__exit__(exc_type, exc, tb)

    def update(
        self, done: int, total: int | None = None, note: str = "", label: str | None = None
    ) -> None:
        """Set the number of items done (and the total, a short note, the label)."""
        self.done = done
        if total is not None:
            self.total = total
        if label is not None:
            self.label = label
        elapsed = time.perf_counter() - self._phase_start
        rate = f"{done / elapsed:.1f}/s" if elapsed > 0 and done else ""
        self.note = " ".join(part for part in (note, rate) if part)
        if self._bar is not None:
            count = f"{done}/{self.total}" if self.total else (str(done) if done else "")
            self._bar.update(
                self._task,
                completed=done,
                total=self.total,
                note=self.note,
                description=self.label,
                count=count,
            )
            return
        now = time.perf_counter()
        if now - self._last_line >= self._interval:
            self._last_line = now
            err_console.print(self.line(), markup=False)

    def phase(self, label: str, note: str = "") -> None:
        """Start a phase: show its label (and a note), no count until the phase reports one.

        On a terminal the bar's label changes at once; elsewhere the next periodic line
        carries it.
        """
        self.label = label
        self.total = None
        self._phase_start = time.perf_counter()
        self.update(0, note=note)

    def advance(self, n: int = 1) -> None:
        """Count ``n`` more items done."""
        self.update(self.done + n)

    def line(self) -> str:
        """Return the one-line progress report."""
        of = f"/{self.total}" if self.total else ""
        pct = f" ({100.0 * self.done / self.total:.0f}%)" if self.total else ""
        unit = f" {self.unit}" if self.unit else ""
        count = f" {self.done}{of}{unit}{pct}" if self.done or self.total else ""
        elapsed = time.perf_counter() - self._start
        note = f" {self.note}" if self.note else ""
        return message_line("progress", f"{self.label}{count}{note} {elapsed:.0f} s")

    def echo(self, message: str) -> None:
        """Print one message line to stderr (above the bar on a terminal)."""
        target = self._bar.console if self._bar is not None else err_console
        target.print(message, markup=False)


def progress(label: str, total: int | None = None, unit: str = "") -> ProgressLine:
    """Return the progress display of one long step; use it as a context manager.

    Args:
        label: What is being done, e.g. ``reprocess``.
        total: Number of items, when known.
        unit: Item name for the one-line report, e.g. ``frames``.
    """
    return ProgressLine(label, total, unit)


def _current_context() -> Context | None:
    """Return the active click context (typer runs on its vendored click)."""
    return get_current_context(silent=True)


def command_line() -> str:
    """Return the command line, for provenance metadata.

    As typed when running as the ``slt`` program; otherwise (the CLI invoked in-process, e.g.
    by a test runner or another tool) rebuilt from the click context's command path and
    parameters, since ``sys.argv`` then belongs to the host program.
    """
    if sys.argv and Path(sys.argv[0]).name == "slt":
        return shlex.join(["slt", *sys.argv[1:]])
    ctx = _current_context()
    if ctx is None:
        return "slt"
    parts = ["slt", *ctx.command_path.split()[1:]]
    for name, value in ctx.params.items():
        if value is None or value is False or value in ((), []):
            continue
        flag = "--" + name.replace("_", "-")
        parts.append(flag if value is True else f"{flag} {shlex.quote(str(value))}")
    return " ".join(parts)
