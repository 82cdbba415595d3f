"""``cavewalk serve`` and ``cavewalk demo``: the dashboard, REST API, WebSocket and 3D view."""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from app.commands.tune import first_start
from app.core.config import get_settings, load_settings, parse_endpoint, set_settings
from pipeline.errors import CavewalkError, ConfigError, InputError
from pipeline.runtime.logfile import log_to_file, to_log_file_only

app = typer.Typer()


def port_free(host: str, port: int) -> bool:
    """True when ``host:port`` can be bound now (TCP)."""
    family = socket.AF_INET6 if ":" in host.strip("[]") else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host.strip("[]"), port))
        except OSError:
            return False
    return True


HostOpt = Annotated[str | None, typer.Option("--host", help="Address to bind (default 127.0.0.1).")]
PortOpt = Annotated[int | None, typer.Option("--port", help="HTTP port (default 8000).", min=1, max=65535)]
ViserOpt = Annotated[
    int | None, typer.Option("--viser-port", help="Port of the 3D view (default 8080).", min=1, max=65535)
]
DbOpt = Annotated[Path | None, typer.Option("--db", help="SQLite database file.")]
ConfigOpt = Annotated[Path | None, typer.Option("--config", help="Settings TOML file.")]
EmitOpt = Annotated[
    list[str] | None,
    typer.Option("--emit", help="HOST:PORT of a workstation to send the UDP stream to (repeatable)."),
]


def run_server(
    *,
    demo: bool,
    host: str | None,
    port: int | None,
    viser_port: int | None,
    db: Path | None,
    config: Path | None,
    emit: list[str] | None,
    people: int | None = None,
    navigation: str | None = None,
) -> None:
    # the web app (FastAPI, uvicorn), the database (SQLAlchemy) and the shared stream are imported here:
    # cavewalk's start-up time
    import uvicorn

    from app.db.engine import DatabaseLock
    from app.db.migrate import prepare_database
    from app.main import create_app, operator_token
    from app.services.backup import backup_before_upgrade
    from pipeline.runtime.stream import check_seq_file

    if config is not None:  # serve and demo also take --config after the command name
        set_settings(load_settings(config))
    settings = first_start(get_settings())  # no tune result on this machine yet: `cavewalk tune` first
    given = {"host": host, "port": port, "viser_port": viser_port}
    server = settings.server.model_copy(update={k: v for k, v in given.items() if v is not None})
    paths = settings.paths if db is None else settings.paths.model_copy(update={"db": db.expanduser()})
    workstations = list(settings.workstations)
    for item in emit or []:
        try:
            parse_endpoint(item)
        except ValueError as exc:
            raise InputError(f"--emit: {exc}") from None
        workstations.append(item)
    update: dict[str, object] = {"server": server, "paths": paths, "workstations": workstations}
    if people is not None:  # demo: that many simulated people step (issue 20)
        update["sim"] = replace(settings.sim, people=people)
    if navigation is not None:
        try:
            update["navigation"] = replace(settings.navigation, mode=navigation,  # type: ignore[arg-type]
                                           user_ids=())
        except ValueError as exc:
            raise InputError(f"--navigation: {exc}") from None
    log = settings.runtime.log
    if log.enabled and log.path is None:  # default: beside the database
        log = replace(log, path=paths.db.expanduser().parent / "logs" / "cavewalk.log")
        update["runtime"] = replace(settings.runtime, log=log)
    # seq goes on across server processes (default: beside the database)
    seq_file = settings.emitter.seq_file or paths.db.expanduser().parent / "stream-seq"
    update["emitter"] = replace(settings.emitter, seq_file=seq_file)
    settings = settings.model_copy(update=update)
    set_settings(settings)
    if paths.db.exists() and paths.db.is_dir():
        raise ConfigError(f"--db {paths.db} is a folder, not a database file")
    if not port_free(server.host, server.port):
        raise ConfigError(f"port {server.port} on {server.host} is in use (choose another with --port)")
    if server.viser and not port_free(server.host, server.viser_port):
        raise ConfigError(f"port {server.viser_port} is in use (choose another with --viser-port)")
    lock = DatabaseLock.acquire(paths.db)  # held until the process ends: a second server stops here
    try:
        try:
            check_seq_file(seq_file)  # a file that holds no seq number: InputError
        except OSError as exc:
            raise ConfigError(f"the stream's seq file {seq_file} cannot be written: "
                              f"{exc.strerror or exc} (set emitter.seq_file)") from None
        try:  # first: the backup and migration lines below go into the file too
            log_file = log_to_file(log, rotate=True)  # this process's log, and the workers' (runtime.log)
        except OSError as exc:
            raise ConfigError(f"the log file {log.path} cannot be written: {exc.strerror or exc} "
                              "(set runtime.log.path, or runtime.log.enabled = false)") from None
        backup_before_upgrade(paths.db, settings.backup)  # an older cavewalk's database: copied first
        prepare_database(paths.db)  # a database that cannot be used ends here with one message
    except BaseException as exc:
        lock.release()
        if isinstance(exc, CavewalkError | OSError):  # the log file says why, as the terminal does
            to_log_file_only(logging.ERROR, f"the server did not start: {exc}", __name__)
        raise
    token = operator_token(settings)
    app = create_app(settings, autostart="simulator" if demo else None, token=token)
    shown = "localhost" if server.host in ("127.0.0.1", "localhost") else server.host
    typer.echo(f"cavewalk dashboard: http://{shown}:{server.port}/  (API docs: /docs)")
    if server.viser:
        typer.echo(f"3D view:            http://{shown}:{server.port}/viewer/")  # proxied, behind the token
    typer.echo(f"database:           {paths.db}")
    typer.echo(f"log file:           {log_file or '(none: runtime.log.enabled = false)'}")
    if token is not None:
        source = "from the settings" if settings.server.token else "generated for this run"
        typer.echo(f"operator token ({source}): {token}")
        typer.echo(f"  open http://{shown}:{server.port}/?token={token}")
    uvicorn.run(
        app, host=server.host.strip("[]"), port=server.port, log_level="warning", ws="websockets-sansio",
        log_config=None,  # uvicorn's records go through the root logger: stderr and the log file
    )


def _command(demo: bool, doc: str) -> Callable[..., None]:
    def command(
        host: HostOpt = None,
        port: PortOpt = None,
        viser_port: ViserOpt = None,
        db: DbOpt = None,
        config: ConfigOpt = None,
        emit: EmitOpt = None,
    ) -> None:
        run_server(demo=demo, host=host, port=port, viser_port=viser_port, db=db, config=config, emit=emit)

    command.__doc__ = doc
    return command


serve = app.command("serve")(
    _command(False, "The dashboard, REST API, WebSocket and viser 3D view (cameras from the settings).")
)
@app.command("demo")
def demo(
    host: HostOpt = None,
    port: PortOpt = None,
    viser_port: ViserOpt = None,
    db: DbOpt = None,
    config: ConfigOpt = None,
    emit: EmitOpt = None,
    people: Annotated[int | None, typer.Option(
        "--people", help="Simulated people who step (default 1, plus the bystanders).", min=1, max=4)] = None,
    navigation: Annotated[str | None, typer.Option(
        "--navigation", help="Navigation mode to start in: single, each or group.")] = None,
) -> None:
    """``serve`` with a simulated CAVE and user: no cameras needed."""
    run_server(demo=True, host=host, port=port, viser_port=viser_port, db=db, config=config, emit=emit,
               people=people, navigation=navigation)
