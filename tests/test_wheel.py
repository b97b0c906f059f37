"""The built wheel works on its own: installed outside the checkout, it finds its data and runs the main jobs."""

from __future__ import annotations

import subprocess
import sys
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
    venv.EnvBuilder(system_site_packages=True, with_pip=True).create(env)
    python = env / "bin" / "python"
    wheel = next((base / "dist").glob("craft_dsl-*.whl"))
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True,
                   capture_output=True)
    return env


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
