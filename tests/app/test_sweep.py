"""``contour-env train --sweep``: the sweep file's checks, a tiny serial sweep whose model DIRs
``contour-env evaluate`` takes, a failed trial recorded, and Ray Tune's figures equal to
the serial ones."""

import json

import pytest

import agents.rl
from contour_env.app.cli import main
from contour_env.app.sweep import load_sweep, trial_name
from contour_env.app.sweep_run import FIGURES, check_ray

TINY = """\
grid:
  case: [sharp-corner]
  seed: [0, 1]
fixed:
  timesteps: 200
  validation_paths: 1
  net_arch: [16, 16]
  teacher: none
"""


def _write(tmp_path, text, name="sweep.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def serial_sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    file = _write(root, TINY)
    rc = main(["train", "--sweep", file, "--out", str(root / "out")])
    return rc, root / "out", file


def _figures(out):
    doc = json.loads((out / "sweep.json").read_text())
    return [(t["name"], t["status"], t["options"], *(t[k] for k in FIGURES)) for t in doc["trials"]]


def test_serial_sweep_writes_model_dirs_that_evaluate_accepts(serial_sweep, capsys):
    rc, out, file = serial_sweep
    assert rc == 0
    doc = json.loads((out / "sweep.json").read_text())
    assert doc["complete"] and doc["executor"] == "serial"
    names = [t["name"] for t in doc["trials"]]
    assert names == ["case=sharp-corner,seed=0", "case=sharp-corner,seed=1"]
    assert (out / "sweep.yaml").read_text() == TINY
    for t in doc["trials"]:
        assert t["status"] == "ok" and t["error"] is None and t["wall_s"] > 0
        assert t["timesteps"] >= 200 and t["validation_rms_contour_error_um"] > 0
        assert t["options"]["timesteps"] == 200 and t["options"]["net_arch"] == [16, 16]
        cfg = json.loads((out / t["name"] / "config.json").read_text())
        assert cfg["seed"] == t["options"]["seed"] and cfg["net_arch"] == [16, 16]
        assert main(["evaluate", "--model", t["model"], "--case", "sharp-corner"]) == 0
        assert "contour error agent/base: RMS" in capsys.readouterr().out
    # the seeds differ, so do the models
    a, b = (t["final_rms_contour_error_um"] for t in doc["trials"])
    assert a != b


def test_failed_trial_is_recorded_and_the_others_are_kept(tmp_path, monkeypatch, capsys):
    real = agents.rl.train

    def train(cfg, out_dir, **kw):
        if cfg.seed == 1:
            raise RuntimeError("unstable: the plant diverged")
        return real(cfg, out_dir, **kw)

    monkeypatch.setattr(agents.rl, "train", train)
    file = _write(tmp_path, TINY.replace("timesteps: 200", "timesteps: 100"))
    assert main(["train", "--sweep", file, "--out", str(tmp_path / "out")]) == 1
    trials = json.loads((tmp_path / "out" / "sweep.json").read_text())["trials"]
    assert [t["status"] for t in trials] == ["ok", "error"]
    assert trials[1]["error"] == "RuntimeError: unstable: the plant diverged"
    assert (tmp_path / "out" / trials[0]["name"] / "model.zip").is_file()
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("[2/2] case=sharp-corner,seed=1: error: Runtime") for line in lines)
    assert lines[-1].startswith("sweep: 1 ok, 1 error")


BAD = [
    ("grid: {seed: [0]}\nbogus: 1\n", "unknown key 'bogus'; allowed: out, grid, fixed"),
    ("grid: {case: [sharp-corner]}\nfixed: {timestep: 5}\n", "fixed.timestep: unknown train"),
    ("grid: {case: []}\n", "grid.case: expected a non-empty list"),
    ("grid: {case: sharp-corner}\n", "grid.case: expected a non-empty list"),
    ("grid: {}\n", "grid: give at least one option"),
    ("grid: {case: [sharp-corner], seed: [0, x]}\n", "grid.seed[1]: invalid int value: 'x'"),
    ("grid: {case: [sharp-corner], algo: [sac, dqn]}\n", "grid.algo[1]: invalid choice: 'dqn'"),
    ("grid: {case: [sharp-corner]}\nfixed: {timesteps: 2.5}\n", "fixed.timesteps: invalid int"),
    ("grid: {case: [sharp-corner]}\nfixed: {ideal: 1}\n", "fixed.ideal: unknown train option"),
    ("grid: {case: [x]}\nfixed: {observe_base_command: 1}\n", "expected true or false"),
    ("grid: {case: [sharp-corner]}\nfixed: {seed: 1}\n", None),  # fine: checked below
    ("grid: {case: [sharp-corner], seed: [0]}\nfixed: {seed: 1}\n", "fixed.seed: in grid too"),
    ("grid: {case: [sharp-corner]}\nfixed: {out: x}\n", "fixed.out: unknown train option"),
    ("grid: {case: [nowhere]}\n", "trial case=nowhere: "),
    ("grid: {case: [sharp-corner]}\nfixed: {base: nope}\n", "base: unknown controller 'nope'"),
    ("grid: {case: [sharp-corner]}\nfixed: {timesteps: 0}\n", "timesteps: expected an integer"),
    ("grid: {case: [sharp-corner]}\nmax_concurrent: 0\n", "max_concurrent: expected an integer"),
    ("grid: {case: ['a:b', a_b]}\n", "get the same folder name 'case=a_b'"),
    ("grid: [case]\n", "grid: expected a mapping"),
    ("- 1\n", "expected a mapping with keys out, grid"),
    ("grid: {case: [sharp-corner]\n", "not valid YAML"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_sweep_file_is_one_line_exit_2_before_training(tmp_path, capsys, text, message):
    file = _write(tmp_path, text)
    out = tmp_path / "out"
    if message is None:
        assert len(load_sweep(file, out=str(out)).trials) == 1
        return
    assert main(["train", "--sweep", file, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {file}: ") and err.count("\n") == 1, err
    assert message in err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["train", "--case", "sharp-corner"], "error: --out: give the output DIR"),
        (["train", "--case", "sharp-corner", "--out", "x", "--ray", "auto"], "--ray: runs the"),
        (["train", "--sweep", "nowhere.yaml", "--out", "x"], "--sweep: no such file"),
        (["train", "--sweep", "s.yaml", "--seed", "3"], "--seed: not with --sweep"),
        (["train", "--sweep", "s.yaml", "--ray", " "], "--ray: give auto"),
    ],
)
def test_command_line_errors(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text(TINY)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_out_from_the_file_and_an_existing_out_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text("out: here\n" + TINY)
    sweep = load_sweep("s.yaml")
    assert sweep.out.name == "here" and len(sweep.trials) == 2
    assert "--out" in sweep.trials[0].argv and "--no-progress" in sweep.trials[0].argv
    (tmp_path / "here" / "case=sharp-corner,seed=1").mkdir(parents=True)
    assert main(["train", "--sweep", "s.yaml"]) == 2
    assert "exists already; use another --out" in capsys.readouterr().err


def test_trial_names_are_readable_and_file_system_safe():
    name = trial_name({"case": "lm-circle3d", "seed": 0, "gcode": ["dir/a b.nc"], "x": "a:b"})
    assert name == "case=lm-circle3d,seed=0,gcode=a_b.nc,x=a_b"


def test_ray_missing_is_a_one_line_hint(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ray.tune", None)
    with pytest.raises(
        ValueError, match=r'--ray: Ray Tune is not installed.*pip install -e "\.\[ray\]"'
    ):
        check_ray("auto")
    assert check_ray(None) is None


@pytest.mark.slow  # Ray's start and two fresh worker processes: about 30-45 s on 2 cores
def test_ray_sweep_gives_the_serial_figures(serial_sweep, tmp_path):
    pytest.importorskip("ray.tune")
    _, serial_out, file = serial_sweep
    out = tmp_path / "ray"
    assert main(["train", "--sweep", file, "--out", str(out), "--ray", "local"]) == 0
    assert _figures(out) == _figures(serial_out)
    doc = json.loads((out / "sweep.json").read_text())
    assert doc["executor"] == "ray local"
    assert (out / "_ray" / "sweep").is_dir()
    for t in doc["trials"]:
        assert (out / t["name"] / "model.zip").is_file()
