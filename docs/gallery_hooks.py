"""How the gallery runs the scripts in ``examples/`` and finds their figures.

Each example is an ordinary command-line script (``python examples/<name>.py
--out <file>``) that writes its figure(s) next to ``--out``. The gallery runs it
with ``--out`` in a folder of its own under ``docs/_build/`` and, in its quick
mode, with the options that keep it short; :func:`written_figures` then hands
the image files the script wrote to sphinx-gallery. So every figure on the site
is exactly what the script writes for a user.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

FIGURES = Path(__file__).resolve().parent / "_build" / "gallery_figures"

# The gallery's order: the paper's figures first, then the other experiments.
ORDER = [
    "jump_linear",
    "jump_linear_sq",
    "robot_contact",
    "rl_cartpole",
    "chirp_spectrogram",
    "gym_pendulum",
    "structural_breaks",
    "sktime_backtest",
]

# Options of each example's quick mode (the default for a script not named: none).
# The chirp runs its full T = 2**14 (a few seconds): the guide describes that setting.
QUICK = {
    "rl_cartpole": ["--quick", "--runs", "1"],
    "gym_pendulum": ["--quick"],
    "sktime_backtest": ["--quick"],
}


def _folder(src_file: str) -> Path:
    return FIGURES / Path(src_file).stem


def example_argv(gallery_conf: dict, script_vars: dict) -> list[str]:
    """The command-line arguments the gallery runs an example with."""
    name = Path(script_vars["src_file"]).stem
    folder = _folder(script_vars["src_file"])
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    # Relative to the folder the example runs in (its own): the example prints the
    # path it was given, and the page should not show this machine's build path.
    out = os.path.relpath(folder / f"{name}.png", Path(script_vars["src_file"]).parent)
    return ["--out", out, *QUICK.get(name, [])]


def written_figures(block, block_vars: dict, gallery_conf: dict) -> str:
    """Move the PNG files the example wrote into the gallery's images (in name order)."""
    images = []
    for path in sorted(_folder(block_vars["src_file"]).glob("*.png")):
        target = next(block_vars["image_path_iterator"])
        shutil.move(path, target)
        images.append(target)
    return figure_rst(images, gallery_conf["src_dir"])


class ExampleOrder:
    """Sort key of the gallery: the position of an example's name in :data:`ORDER`."""

    def __init__(self, src_dir: str) -> None:
        self.src_dir = src_dir

    def __call__(self, filename: str) -> tuple[int, str]:
        stem = Path(filename).stem
        return (ORDER.index(stem) if stem in ORDER else len(ORDER), stem)

    def __repr__(self) -> str:  # sphinx-gallery compares configurations by repr
        return f"ExampleOrder({ORDER})"
