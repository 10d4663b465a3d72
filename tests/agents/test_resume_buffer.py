"""Resuming SAC keeps every replay-buffer transition (issue 20 item 4: one was lost per resume,
the periodic checkpoint was written before sb3 stored the step's transition)."""

import json
import pickle
import shutil

from agents.rl import TrainConfig, train
from agents.rl.checkpoint import checkpoint_dirs

SHORT = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"
TINY = dict(
    plant="friction-table",
    seed=0,
    learning_starts=50,
    buffer_size=2000,
    batch_size=32,
    eval_freq=150,
    checkpoint_freq=150,
    net_arch=(16, 16),
    # no keep-best validation episodes: this test is about the replay buffer
    validation_paths=0,
    teacher="none",
)


def _buffer_sizes(out):
    sizes = {}
    for ck in checkpoint_dirs(out / "checkpoints"):
        with open(ck / "replay_buffer.pkl", "rb") as fh:
            rb = pickle.load(fh)
        steps = json.loads((ck / "state.json").read_text())["timesteps"]
        sizes[steps] = rb.buffer_size if rb.full else rb.pos
    return sizes


def test_sac_resumed_twice_from_periodic_checkpoints_keeps_every_transition(tmp_path):
    gcode = tmp_path / "short.nc"
    gcode.write_text(SHORT)
    out = tmp_path / "run"
    for i, timesteps in enumerate((350, 500, 650)):
        if i:
            # an interrupted run: only the periodic checkpoint (written during learn) is left
            shutil.rmtree(checkpoint_dirs(out / "checkpoints")[-1])
        cfg = TrainConfig(gcode=(str(gcode),), algo="sac", timesteps=timesteps, **TINY)
        train(cfg, out, resume=i > 0, progress=False, log=lambda s: None)
        sizes = _buffer_sizes(out)
        # every checkpoint, periodic or final, holds one transition per timestep
        assert sizes and all(n == steps for steps, n in sizes.items()), sizes
    assert max(sizes) == 650
