"""Settings and the foundation commands, through the real CLI."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.core.config import load_settings, set_settings
from pipeline.errors import ConfigError
from tests.app.test_cli_errors import run_cli

runner = CliRunner()


@pytest.fixture(autouse=True)
def _reset_settings():
    yield
    set_settings(None)


def test_defaults_describe_a_four_wall_cave() -> None:
    s = load_settings()
    cave = s.cave.geometry()
    assert [w.name for w in cave.walls] == ["front", "right", "back", "left"]
    assert cave.height_m == pytest.approx(2.5)
    assert [c.name for c in s.cameras] == ["cam01", "cam02", "cam03", "cam04"]


def test_toml_file_and_env_override(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text('workstations = ["10.0.0.5:7000"]\n[server]\nport = 9001\n[cave]\nwidth_m = 4.0\n')
    monkeypatch.setenv("CAVEWALK_SERVER__VISER_PORT", "9100")
    s = load_settings(cfg)
    assert s.server.port == 9001
    assert s.server.viser_port == 9100, "environment variables override the file"
    assert s.cave.geometry().wall("front").width_m == pytest.approx(4.0)
    assert s.workstations == ["10.0.0.5:7000"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[server]\nprot = 9001\n", r"server\.prot"),
        ("[server]\nport = 99999\n", r"server\.port"),
        ('workstations = ["nohost"]\n', r"workstations"),
        ("[cave]\nwidth_m = -1\n", r"cave\.width_m"),
        ("[server\nport=1", r"cannot read settings"),
    ],
)
def test_invalid_file_names_the_bad_key(tmp_path: Path, text: str, match: str) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    with pytest.raises(ConfigError, match=match):
        load_settings(cfg)


def test_config_show_prints_effective_settings(tmp_path: Path) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text("[server]\nport = 9002\n")
    result = runner.invoke(cli, ["--config", str(cfg), "config", "show", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["server"]["port"] == 9002


# The real entry point app.cli.main in this process (an interpreter per case costs ~3 s of imports; an
# exception escaping main() fails the test, as in tests/app/test_cli_errors.py).
def test_cli_bad_config_is_one_clear_message(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[server]\nprot = 1\n")
    code = run_cli(["--config", str(cfg), "config", "show"], monkeypatch)
    err = capsys.readouterr().err
    assert code == 2
    assert "server.prot" in err
    assert "Traceback" not in err


def test_cli_missing_config_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    code = run_cli(["--config", str(tmp_path / "nope.toml"), "config", "show"], monkeypatch)
    assert code == 2 and "config file not found" in capsys.readouterr().err


def test_the_default_database_is_in_the_users_data_directory() -> None:
    """Issue 19.11: not /var/lib; README and PathSettings agree."""
    from pathlib import Path

    from app.core.config import USER_DATA_DIR, load_settings

    db = load_settings().paths.db
    assert db == USER_DATA_DIR / "cavewalk.db" and USER_DATA_DIR.name == "cavewalk"
    assert not str(db).startswith("/var/"), db
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    assert "/var/lib/cavewalk" not in readme
    assert "~/.local/share/cavewalk/cavewalk.db" in readme, "the README names the default database"


@pytest.mark.parametrize("how", ["cwd", "env", "option"])
def test_a_config_that_is_a_folder_is_an_error(
    how: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A folder named cavewalk.toml was silently ignored (issue 15): the defaults ran instead."""
    folder = tmp_path / "cavewalk.toml"
    folder.mkdir()
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("CAVEWALK_CONFIG", raising=False)
    if how == "env":
        monkeypatch.chdir(tmp_path.parent)
        monkeypatch.setenv("CAVEWALK_CONFIG", str(folder))
    with pytest.raises(ConfigError, match="is a folder, not a TOML settings file"):
        load_settings(folder if how == "option" else None)
    args = ["--config", str(folder)] if how == "option" else []
    capsys.readouterr()
    code = run_cli([*args, "config", "show"], monkeypatch)  # the real entry point, in this process
    out, err = capsys.readouterr()
    assert code == 2, out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: config "), err
    assert lines[0].endswith("cavewalk.toml is a folder, not a TOML settings file"), lines
