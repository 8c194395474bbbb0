"""Where the shipped configs and agents are found (wheel and checkout layouts), what a config
argument means, and the packaging that puts them in the wheel (wheelgym.resources)."""

from __future__ import annotations

import fnmatch
import os
import subprocess
import sys
from pathlib import Path

import pytest

import wheelgym
from wheelgym import resources

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


@pytest.fixture(autouse=True)
def _no_override(monkeypatch):
    monkeypatch.delenv(resources.PRETRAINED_ENV, raising=False)


# --------------------------------------------------------------------------------------------
# the checkout layout (source tree on the path, or an editable install)
# --------------------------------------------------------------------------------------------


def test_checkout_layout_finds_the_repository_folders():
    assert resources.package_root() == Path(wheelgym.__file__).parent
    assert resources.repository_root() == ROOT
    assert resources.configs_dir() == ROOT / "configs"
    assert resources.pretrained_dir() == ROOT / "agents" / "pretrained"
    assert resources.pretrained_dir(for_writing=True) == ROOT / "agents" / "pretrained"
    assert resources.results_csv() == ROOT / "benchmarks" / "results" / "training.csv"
    assert resources.config_names() == sorted(p.stem for p in (ROOT / "configs").glob("*.yml"))
    assert resources.default_config() == ROOT / "configs" / f"{resources.DEFAULT_CONFIG}.yml"
    assert resources.runs_dir("tune") == Path("runs") / "tune"


def test_the_current_folder_never_takes_over(tmp_path, monkeypatch):
    decoy = tmp_path / "configs" / f"{resources.DEFAULT_CONFIG}.yml"
    decoy.parent.mkdir()
    decoy.write_text("not: [a config\n")
    (tmp_path / "agents" / "pretrained").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)
    assert resources.configs_dir() == ROOT / "configs"
    assert resources.default_config() == ROOT / "configs" / decoy.name
    assert resources.config_path(resources.DEFAULT_CONFIG) == ROOT / "configs" / decoy.name
    assert resources.config_path(decoy.name) == ROOT / "configs" / decoy.name
    assert resources.pretrained_dir() == ROOT / "agents" / "pretrained"
    # an explicit path wins, relative or absolute
    assert resources.config_path(Path("configs") / decoy.name) == Path("configs") / decoy.name
    assert resources.config_path(decoy) == decoy
    mine = tmp_path / "mine.yml"
    mine.write_text("x: 1\n")
    assert resources.config_path("mine.yml") == Path("mine.yml")


def test_a_configs_folder_in_the_current_folder_does_not_take_over_the_benchmark(tmp_path,
                                                                                 monkeypatch):
    pytest.importorskip("stable_baselines3")
    from wheelgym.agents.benchmark import DEFAULT_CSV, default_configs

    (tmp_path / "configs").mkdir()
    (tmp_path / "configs" / "Mine-goal-x.yml").write_text("x: 1\n")
    monkeypatch.chdir(tmp_path)
    assert default_configs() == sorted((ROOT / "configs").glob("*.yml"))
    assert DEFAULT_CSV == ROOT / "benchmarks" / "results" / "training.csv"


def test_a_bad_config_argument_names_the_argument_and_the_choices(tmp_path):
    with pytest.raises(ValueError, match=r"--config 'ThreeWheel-goal-velcity': file not found "
                                         r"and no shipped config.*did you mean "
                                         r"'ThreeWheel-goal-velocity'.*shipped names: "
                                         r"Ackermann-goal-.*Unicycle-track-"):
        resources.config_path("ThreeWheel-goal-velcity", "--config")
    with pytest.raises(ValueError, match=r"CONFIG 'nowhere/ThreeWheel-goal-velocity.yml': file "
                                         r"not found \(the shipped config of that name is "
                                         r"'ThreeWheel-goal-velocity', without a folder\)"):
        resources.config_path("nowhere/ThreeWheel-goal-velocity.yml")
    with pytest.raises(ValueError, match="is a folder"):
        resources.config_path(tmp_path, "CONFIG")


def test_the_cli_resolves_config_names(capsys, tmp_path, monkeypatch):
    from wheelgym.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["configs"]) == 0
    out, err = capsys.readouterr()
    assert out.split() == resources.config_names() and "configs in" in err
    assert main(["configs", resources.DEFAULT_CONFIG]) == 0
    out, _ = capsys.readouterr()
    assert out == resources.default_config().read_text(encoding="utf-8")
    for argv in (["train", "Nope"], ["main", "--config", "Nope"], ["tune", "Nope"],
                 ["benchmark", "Nope"], ["configs", "Nope"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "'Nope': file not found" in err and resources.DEFAULT_CONFIG in err, (argv, err)
    assert not list(tmp_path.iterdir())  # nothing written on a bad argument


# --------------------------------------------------------------------------------------------
# the wheel layout: the files inside the package, no repository around it
# --------------------------------------------------------------------------------------------


def _installed(tmp_path: Path, monkeypatch, with_data: bool = True) -> Path:
    pkg = tmp_path / "site-packages" / "wheelgym"
    pkg.mkdir(parents=True)
    if with_data:
        (pkg / "configs").mkdir()
        (pkg / "configs" / f"{resources.DEFAULT_CONFIG}.yml").write_text("x: 1\n")
        (pkg / "pretrained" / "A").mkdir(parents=True)
    monkeypatch.setattr(resources, "package_root", lambda: pkg)
    return pkg


def test_wheel_layout_reads_the_package_data(tmp_path, monkeypatch):
    pkg = _installed(tmp_path, monkeypatch)
    (tmp_path / "configs").mkdir()  # a folder of the user's own, beside the package
    assert resources.repository_root() is None
    assert resources.configs_dir() == pkg / "configs"
    assert resources.config_names() == [resources.DEFAULT_CONFIG]
    assert resources.default_config() == pkg / "configs" / f"{resources.DEFAULT_CONFIG}.yml"
    assert resources.pretrained_dir() == pkg / "pretrained"
    assert resources.results_csv() == Path("runs") / "benchmark" / "training.csv"
    with pytest.raises(ValueError, match=r"--root FOLDER.*not written to"):
        resources.pretrained_dir(for_writing=True)
    monkeypatch.setenv(resources.PRETRAINED_ENV, str(tmp_path / "mine"))
    assert resources.pretrained_dir(for_writing=True) == tmp_path / "mine"
    assert resources.pretrained_dir(tmp_path / "x") == tmp_path / "x"


def test_wheel_without_its_data_is_a_clear_error(tmp_path, monkeypatch):
    _installed(tmp_path, monkeypatch, with_data=False)
    with pytest.raises(ValueError, match=r"shipped configs are missing.*Reinstall"):
        resources.configs_dir()
    with pytest.raises(ValueError, match=r"shipped configs are missing.*or give --config FILE"):
        resources.default_config()
    with pytest.raises(ValueError, match=r"shipped pretrained agents are missing"):
        resources.pretrained_dir()


# --------------------------------------------------------------------------------------------
# packaging: what pyproject.toml maps into the wheel is what resources reads
# --------------------------------------------------------------------------------------------


def test_pyproject_maps_the_shipped_folders_into_the_package():
    tool = PYPROJECT["tool"]["setuptools"]
    mapped = {pkg.removeprefix("wheelgym."): Path(src)
              for pkg, src in tool["package-dir"].items()}
    assert mapped == resources._SHIPPED
    setup_py = (ROOT / "setup.py").read_text(encoding="utf-8")
    for kind in mapped:
        assert f'"wheelgym.{kind}"' in setup_py  # listed as packages of the wheel


@pytest.mark.parametrize("kind", sorted(resources._SHIPPED))
def test_package_data_covers_every_shipped_file(kind):
    patterns = PYPROJECT["tool"]["setuptools"]["package-data"][f"wheelgym.{kind}"]
    base = ROOT / resources._SHIPPED[kind]
    files = [p.relative_to(base).as_posix() for p in base.rglob("*")
             if p.is_file() and "__pycache__" not in p.parts]
    assert files
    left = [f for f in files if not any(fnmatch.fnmatchcase(f, pat) and
                                        f.count("/") == pat.count("/") for pat in patterns)]
    assert not left, f"files under {base} that the wheel would leave out: {left}"


def test_the_version_has_one_source():
    project = PYPROJECT["project"]
    assert "version" not in project and "version" in project["dynamic"]
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "wheelgym.__version__"}
    hits = [p for p in (ROOT / "wheelgym").rglob("*.py")
            if "__version__ =" in p.read_text(encoding="utf-8")]
    assert hits == [ROOT / "wheelgym" / "__init__.py"]


def test_no_gymnasium_entry_point_is_claimed():
    """Gymnasium >= 1.0 loads no plugin entry points; ids are reached with the ``wheelgym:``
    prefix (tests/test_registration.py)."""
    assert "gymnasium.envs" not in PYPROJECT["project"].get("entry-points", {})


def test_editable_install_of_this_checkout_finds_the_repository_folders(tmp_path):
    """The installed ``wheelgym`` (``make test``: an editable install of this tree), imported in
    a fresh interpreter from an empty folder, without this tree on ``PYTHONPATH``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = ("import wheelgym, json\n"
            "from wheelgym import resources as r\n"
            "print(json.dumps([wheelgym.__file__, str(r.configs_dir()), str(r.pretrained_dir()),"
            " str(r.default_config())]))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    where = subprocess.run([sys.executable, "-c", "import wheelgym; print(wheelgym.__file__)"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    if where.returncode != 0 or Path(where.stdout.strip()).parent != ROOT / "wheelgym":
        pytest.skip(f"the installed wheelgym is not an editable install of {ROOT} "
                    f"({where.stdout.strip() or where.stderr.strip()[-200:]})")
    assert proc.returncode == 0, proc.stderr[-2000:]
    import json

    _, configs, agents, default = json.loads(proc.stdout)
    assert Path(configs) == ROOT / "configs" and Path(agents) == ROOT / "agents" / "pretrained"
    assert Path(default) == ROOT / "configs" / f"{resources.DEFAULT_CONFIG}.yml"
