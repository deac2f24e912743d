"""Root ``slt`` Typer app: joins the command groups and guards against tracebacks."""

from __future__ import annotations

import sys

import typer

from superlane_tools._version import __version__
from superlane_tools.cli import (
    batch,
    camera,
    compare,
    convert,
    corridor,
    dbc,
    extract,
    history,
    info,
    lanes,
    mine,
    recover,
    reprocess,
    segment,
    simulate,
    tables,
    tools,
    train,
)
from superlane_tools.cli import eval as eval_cmd
from superlane_tools.cli._common import (
    CONTEXT_SETTINGS,
    EXIT_CODES_HELP,
    SltGroup,
    debug_enabled,
    say,
)
from superlane_tools.errors import ExitCode

app = typer.Typer(
    name="slt",
    help=(
        "superlane-tools: inspect, extract and reprocess driving recordings "
        f"with the SUPER lane-detection stack.\n\n{EXIT_CODES_HELP}"
    ),
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    add_completion=False,
    rich_markup_mode=None,
    cls=SltGroup,
    context_settings=CONTEXT_SETTINGS,
)


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"slt {__version__}")
        raise typer.Exit


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True, help="Show the version."
    ),
) -> None:
    """Inspect, extract and reprocess driving recordings."""


reprocess.register(app)
batch.register(app)
info.register(app)
extract.register(app)
simulate.register(app)
camera.register(app)
lanes.register(app)
segment.register(app)
corridor.register(app)
train.register(app)
eval_cmd.register(app)
tables.register(app)
convert.register(app)
tools.register(app)
recover.register(app)
dbc.register(app)
compare.register(app)
mine.register(app)
history.register(app)


def main() -> None:
    """Console-script entry point: run the app; turn unexpected errors into one line."""
    try:
        app(standalone_mode=True)
    except SystemExit:
        raise
    except KeyboardInterrupt:
        say("error", "interrupted")
        sys.exit(130)
    except Exception as err:  # last line of defence against tracebacks
        if debug_enabled():
            raise
        say("error", f"internal error: {type(err).__name__}: {err} (SLT_DEBUG=1: traceback)")
        sys.exit(int(ExitCode.ERROR))
