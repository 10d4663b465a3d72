"""contour_env.io: atomic writes whose files get the process umask's mode (0644 under 022)."""

import io
import json
import os
import stat
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from contour_env.io import (  # noqa: E402
    atomic_save,
    atomic_save_figure,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    current_umask,
    default_mode,
)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask():
    """Set the process umask for one test, restoring it afterwards."""
    old = os.umask(0o022)
    os.umask(old)
    yield os.umask
    os.umask(old)


def _write_every_kind(folder: Path) -> list[Path]:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    buf = io.BytesIO()
    np.savez_compressed(buf, u=np.arange(3.0))
    try:
        return [
            atomic_write_json(folder / "a.json", {"x": 1}),
            atomic_write_text(folder / "b.txt", "text\n"),
            atomic_write_bytes(folder / "c.npz", buf.getvalue()),
            atomic_save_figure(fig, folder / "d.png", dpi=50),
            atomic_save(folder / "e.npz", lambda tmp: np.savez(tmp, u=np.ones(2))),
        ]
    finally:
        plt.close(fig)


@pytest.mark.parametrize("mask, expected", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_written_files_get_the_umask_mode_not_mkstemps_0600(tmp_path, umask, mask, expected):
    umask(mask)
    assert current_umask() == mask
    assert default_mode() == expected and default_mode(directory=True) == 0o777 & ~mask
    for path in _write_every_kind(tmp_path / "out"):
        assert _mode(path) == expected, path.name
    # overwriting keeps the rule (the new file replaces the old one)
    umask(0o022)
    assert _mode(atomic_write_json(tmp_path / "out" / "a.json", {"x": 2})) == 0o644
    # no temporary file is left behind
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "a.json",
        "b.txt",
        "c.npz",
        "d.png",
        "e.npz",
    ]
    assert json.loads((tmp_path / "out" / "a.json").read_text()) == {"x": 2}
    assert np.load(tmp_path / "out" / "e.npz")["u"].shape == (2,)


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path, umask):
    umask(0o022)
    target = atomic_write_text(tmp_path / "keep.txt", "old\n")

    def boom(tmp):
        Path(tmp).write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_save(target, boom)
    with pytest.raises(ValueError):
        atomic_write_json(target, {"x": float("nan")})  # allow_nan=False: before any write
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_checkpoint_directories_and_trainer_files_get_the_umask_mode(tmp_path, umask):
    """agents.rl: checkpoints were mkdtemp directories (0700) renamed into place, and
    model.zip / vecnormalize.pkl were written into mkstemp files (0600)."""
    from agents.rl import trainer
    from agents.rl.checkpoint import write_checkpoint

    umask(0o022)
    folder = write_checkpoint(
        tmp_path / "checkpoints",
        100,
        lambda d: atomic_write_json(d / "state.json", {"timesteps": 100}),
        keep=2,
    )
    assert _mode(folder) == 0o755
    assert all(_mode(p) == 0o644 for p in folder.iterdir())
    # the trainer writes model.zip / vecnormalize.pkl (final/ and the kept model) through
    # contour_env.io.atomic_save
    assert trainer.atomic_save is atomic_save
    trainer.atomic_save(tmp_path / "model.zip", lambda p: Path(p).write_bytes(b"PK"))
    assert _mode(tmp_path / "model.zip") == 0o644
