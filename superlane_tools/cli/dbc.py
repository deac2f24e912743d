"""`slt dbc show`: a DBC file as slt loads it, with every repair made."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import cli_errors

dbc_app = typer.Typer(
    name="dbc",
    help="CAN databases: show a DBC as slt loads it (messages, signals, units, enums, repairs).",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@dbc_app.command("show")
def show_cmd(
    dbc: Annotated[Path, typer.Argument(help="DBC file.", show_default=False)],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
    message: Annotated[
        str | None,
        typer.Option("--message", "-m", help="Only this message (name or id, e.g. 0x766)."),
    ] = None,
) -> None:
    """Show the messages, signals, units and enums of a DBC and every repair slt made."""
    from superlane_tools.commands.dbc import show

    with cli_errors():
        doc = show(dbc, message)
    if as_json:
        typer.echo(json.dumps(doc, indent=2))
        return
    typer.echo(f"{dbc.name}: {len(doc['messages'])} messages, {len(doc['repairs'])} repair(s)")
    for line in doc["repairs"]:
        typer.echo(f"  repair: {line}")
    for msg in doc["messages"]:
        ext = " extended" if msg["is_extended"] else ""
        typer.echo(
            f"{msg['id_hex']} {msg['name']} ({msg['length']} bytes{ext}, "
            f"{msg['cycle_time_ms'] or '-'} ms, senders: {', '.join(msg['senders']) or '-'})"
        )
        for sig in msg["signals"]:
            unit = f" [{sig['unit']}]" if sig["unit"] else ""
            typer.echo(
                f"  {sig['name']}: bit {sig['start']} len {sig['length']} "
                f"{sig['byte_order']} {'signed' if sig['is_signed'] else 'unsigned'} "
                f"x{sig['scale']:g} +{sig['offset']:g}{unit} "
                f"[{sig['minimum']}, {sig['maximum']}]"
            )
            for value, label in sig["choices"].items():
                typer.echo(f"      {value} = {label}")


def register(app: typer.Typer) -> None:
    """Add the ``dbc`` command group to the root app."""
    app.add_typer(dbc_app, name="dbc")
