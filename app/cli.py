"""The ``cavewalk`` command line.

Each command group lives in ``app/commands/<name>.py`` and exposes
``register(cli)``. Errors a user can cause (:class:`pipeline.errors.CavewalkError`)
end with one message on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import importlib
import logging
import sys
from pathlib import Path
from typing import Annotated

import typer

from app.core.config import load_settings, set_settings
from app.core.logging import configure_logging
from pipeline.errors import CavewalkError

cli = typer.Typer(
    name="cavewalk",
    help="Markerless full-body locomotion for CAVE virtual-reality rooms.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

# Command modules, each with register(cli). Order = order in --help.
COMMAND_MODULES: tuple[str, ...] = (
    "app.commands.config",
    "app.commands.models",
    "app.commands.data",
    "app.commands.calibration",
    "app.commands.process",
    "app.commands.recognize",
    "app.commands.evaluate",
    "app.commands.serve",
    "app.commands.study",
    "app.commands.runtime",
    "app.commands.simulate",
    "app.commands.plan",
)

log = logging.getLogger(__name__)


@cli.callback()
def _root(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Debug logging.")] = False,
    config: Annotated[
        Path | None, typer.Option("--config", help="Settings TOML file (default ./cavewalk.toml).")
    ] = None,
) -> None:
    configure_logging(logging.DEBUG if verbose else logging.INFO)
    set_settings(load_settings(config))


def apply_config(config: Path | None) -> None:
    """For commands that also take --config themselves (serve, demo)."""
    if config is not None:
        set_settings(load_settings(config))


def _register_all() -> None:
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(cli)


_register_all()


def main() -> None:
    """Console-script entry point."""
    try:
        cli(prog_name="cavewalk")
    except CavewalkError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except KeyboardInterrupt:
        typer.echo("interrupted", err=True)
        sys.exit(130)


if __name__ == "__main__":
    main()
