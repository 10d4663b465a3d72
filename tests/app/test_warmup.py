"""contour_env.app.warmup: compiling the kernels ahead of use (contour-env warm)."""

from __future__ import annotations

import pytest

from contour_env.app import warmup
from contour_env.app.cli import main


def test_unknown_part_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="part: unknown 'nope'; known: plant, five-axis"):
        warmup.warm_part("nope")


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_workers_must_be_a_positive_integer(workers):
    with pytest.raises(ValueError, match="workers: a positive integer"):
        warmup.warm(workers)


def test_a_failing_part_raises_naming_it(monkeypatch):
    # the part runs in a child process; its failure comes back as one line naming the part
    monkeypatch.setattr(warmup, "STAGES", (("no-such-part",),))
    with pytest.raises(RuntimeError, match="warm-up of 'no-such-part' failed: ValueError: part"):
        warmup.warm(1)


def test_plant_part_runs_in_process_and_leaves_the_slow_path_cached():
    warmup.warm_part("plant")
    assert warmup.cache_is_cold() is False


def test_cli_warm_refuses_zero_workers(capsys):
    assert main(["warm", "--workers", "0"]) == 2
    assert "--workers: a positive integer, got 0" in capsys.readouterr().err


@pytest.mark.parametrize("part", sorted(set(warmup.PARTS) - {"batch"}))
def test_every_part_runs_against_the_current_kernels(part):
    # a part calls the kernels the way the library does; a signature change that the
    # warm-up missed fails here, not only on a cold cache (CI's first run)
    warmup.warm_part(part)
