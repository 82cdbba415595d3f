"""The ``cavewalk`` command line.

Each command (or command group) lives in ``app/commands/<name>.py`` as a module-level
Typer app named ``app``; this module adds them in the order of ``--help``. Errors a user
can cause (:class:`pipeline.errors.CavewalkError`) end with one message on stderr and
exit status 2, never a traceback.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import Annotated

import typer

from app.commands import (
    calibration,
    config,
    data,
    db,
    evaluate,
    export,
    models,
    plan,
    process,
    recognize,
    record,
    runtime,
    serve,
    simulate,
    study,
    train,
    tune,
)
from app.core.config import load_settings, set_settings
from app.core.logging import configure_logging
from pipeline.errors import CavewalkError

try:  # typer >= 0.2x carries its own copy of click
    from typer._click import exceptions as click_exceptions
except ImportError:  # older typer runs on click itself
    from click import exceptions as click_exceptions  # type: ignore[no-redef]

cli = typer.Typer(
    name="cavewalk",
    help="Markerless full-body locomotion for CAVE virtual-reality rooms.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


@cli.callback()
def _root(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Debug logging.")] = False,
    config_file: Annotated[
        Path | None, typer.Option("--config", help="Settings TOML file (default ./cavewalk.toml).")
    ] = None,
) -> None:
    configure_logging(logging.DEBUG if verbose else logging.INFO)
    set_settings(load_settings(config_file))


cli.add_typer(config.app)  # cavewalk config show
cli.add_typer(models.app)  # cavewalk models prepare
cli.add_typer(data.app)  # cavewalk data demo
cli.add_typer(calibration.app)  # cavewalk calibration pattern|layout|checkerboard, cavewalk calibrate
cli.add_typer(process.app)  # cavewalk process
cli.add_typer(recognize.app)  # cavewalk recognize
cli.add_typer(evaluate.app)  # cavewalk evaluate
cli.add_typer(serve.app)  # cavewalk serve, cavewalk demo
cli.add_typer(study.app)  # cavewalk study report
cli.add_typer(db.app)  # cavewalk db backup|backups|restore
cli.add_typer(runtime.app)  # cavewalk receive, cavewalk bench
cli.add_typer(simulate.app)  # cavewalk simulate
cli.add_typer(plan.app)  # cavewalk plan
cli.add_typer(record.app)  # cavewalk record
cli.add_typer(export.app)  # cavewalk export
cli.add_typer(train.app)  # cavewalk train
cli.add_typer(tune.app)  # cavewalk tune


def main() -> None:
    """Console-script entry point: a bad invocation or input ends with one ``error:`` line on
    stderr and a non-zero exit status (2), never a traceback."""
    try:
        code = cli(prog_name="cavewalk", standalone_mode=False)
    except click_exceptions.NoArgsIsHelpError as exc:  # a bare group: its help, as before
        typer.echo(exc.ctx.get_help(), err=True)
        sys.exit(2)
    except click_exceptions.ClickException as exc:  # usage errors, in the same one-line form as ours
        ctx = getattr(exc, "ctx", None)
        hint = f" (see: {ctx.command_path} --help)" if ctx is not None else ""
        typer.echo(f"error: {exc.format_message()}{hint}", err=True)
        sys.exit(exc.exit_code)
    except CavewalkError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except (KeyboardInterrupt, typer.Abort):
        typer.echo("interrupted", err=True)
        sys.exit(130)
    except OSError as exc:  # a file or device the command could not use
        where = f": {exc.filename}" if exc.filename else ""
        typer.echo(f"error: {exc.strerror or exc}{where}", err=True)
        sys.exit(2)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
