"""``cavewalk config show``: the effective settings."""

from __future__ import annotations

import json

import tomli_w
import typer

from app.core.config import get_settings

app = typer.Typer(name="config", help="Inspect the settings.", no_args_is_help=True)


@app.command("show")
def show(
    as_json: bool = typer.Option(False, "--json", help="JSON instead of TOML."),
) -> None:
    """Print the effective settings (defaults + cavewalk.toml + CAVEWALK_* variables)."""
    data = get_settings().dump()
    if as_json:
        typer.echo(json.dumps(data, indent=2))
    else:
        typer.echo(tomli_w.dumps(data))
