"""The built wheel works on its own: installed outside the checkout, it finds its data and runs the main jobs."""

from __future__ import annotations

import site
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment outside the checkout with the wheel installed (dependencies from the
    surrounding environment, so that no download is needed)."""
    base = tmp_path_factory.mktemp("wheel")
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(base / "dist"),
                            str(ROOT)], capture_output=True, text=True, check=False)
    if build.returncode != 0:
        pytest.fail(f"building the wheel failed:\n{build.stderr[-2000:]}")
    env = base / "venv"
    venv.EnvBuilder(with_pip=True).create(env)
    python = env / "bin" / "python"
    _see_surrounding_packages(python)
    wheel = next((base / "dist").glob("craft_dsl-*.whl"))
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True,
                   capture_output=True)
    return env


def surrounding_site_dirs() -> list[str]:
    """The site-packages folders of the interpreter running the tests, whether it is a venv or a system one.

    ``system_site_packages=True`` would show the *base* interpreter's packages, which from inside a venv are
    not the ones the tests run with."""
    dirs = [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"], *site.getsitepackages()]
    if site.ENABLE_USER_SITE:
        dirs.append(site.getusersitepackages())
    return list(dict.fromkeys(d for d in dirs if Path(d).is_dir()))


def _see_surrounding_packages(python: Path) -> None:
    """Append the surrounding site folders to the new venv's path with a ``.pth`` file.

    The venv's own site-packages stays first, so the installed wheel shadows the checkout's editable install; the
    editable install's own ``.pth`` in the surrounding folder is not processed (a path line in a ``.pth`` file adds
    the folder, not its ``.pth`` files), so the checkout is never imported by mistake."""
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    Path(purelib, "_surrounding_packages.pth").write_text("".join(d + "\n" for d in surrounding_site_dirs()))


def test_surrounding_packages_are_found_from_any_interpreter(installed: Path, tmp_path: Path) -> None:
    """The venv imports the test environment's dependencies, whether the tests run in a venv or not."""
    res = _run(installed, "python", "-c", "import pymunk, numpy, lark, pydantic, networkx; print('ok')", cwd=tmp_path)
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr


def _run(env: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(env / "bin" / a) if i == 0 else a for i, a in enumerate(args)], cwd=cwd,
                          capture_output=True, text=True, check=False)


def test_the_wheel_carries_its_data_and_types(installed: Path, tmp_path: Path) -> None:
    res = _run(installed, "python", "-c", "import craft_dsl, craft_dsl.resources as r, pathlib; "
               "print(craft_dsl.__file__); print(r.data_dir('scenes')); "
               "print((pathlib.Path(craft_dsl.__file__).parent / 'py.typed').exists())", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    module, scenes, typed = res.stdout.split()
    assert str(installed) in module and str(installed) in scenes and typed == "True"


def test_demo_and_generation_run_from_the_wheel(installed: Path, tmp_path: Path) -> None:
    demo = _run(installed, "craft-dsl", "demo", cwd=tmp_path)
    assert demo.returncode == 0, demo.stderr
    gen = _run(installed, "craft-dsl", "generate", "--size", "2", "--scenes", "1", "--no-balance",
               "--out", str(tmp_path / "ds"), "--quiet", cwd=tmp_path)
    assert gen.returncode == 0, gen.stderr
    assert (tmp_path / "ds" / "dataset.json").is_file()
