"""contour-env export: the C and ONNX forms and the README of a shipped agent, the zero law of
one kept as its base, --bench, and one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from contour_env.app.cli import main

MODELS = Path(__file__).resolve().parents[2] / "agents" / "models"


def test_export_writes_c_onnx_and_a_readme_of_the_interface(tmp_path, capsys):
    pytest.importorskip("onnx")
    out = tmp_path / "lm"
    js = tmp_path / "iface.json"
    assert main(["export", "--model", str(MODELS / "linear-motor"), "--out", str(out),
                 "--json", str(js)]) == 0  # fmt: skip
    for name in ("residual.c", "residual.h", "residual.onnx", "README.md"):
        assert (out / name).is_file(), name
    text = (out / "README.md").read_text()
    assert "**Servo period**: 0.0001 s" in text and "every 10 periods the network runs" in text
    assert (
        "| `encoder_position` | m | 3 |" in text
        and "| `residual` | fraction of force limit |" in text
    )
    iface = json.loads(js.read_text())["interface"]
    assert iface["n_axes"] == 3 and iface["law"]["residual_frame"] == "path"
    assert "wrote" in capsys.readouterr().out


def test_a_kept_base_agent_exports_the_zero_law_and_says_so(tmp_path):
    out = tmp_path / "ft"
    assert main(["export", "--model", str(MODELS / "friction-table"), "--out", str(out),
                 "--format", "c"]) == 0  # fmt: skip
    assert not (out / "residual.onnx").exists()
    assert "**Zero law**" in (out / "README.md").read_text()
    assert "ZERO LAW" in (out / "residual.h").read_text()


def test_bench_prints_microseconds_per_call(tmp_path, capsys):
    from agents.export.bench import compiler

    if compiler() is None:
        pytest.skip("no C compiler")
    out = tmp_path / "b"
    assert main(["export", "--model", str(MODELS / "linear-motor"), "--out", str(out),
                 "--format", "c", "--bench"]) == 0  # fmt: skip
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("C law:"))
    assert "median" in line and "p99" in line and "µs per call" in line
    assert "## Latency on the exporting machine" in (out / "README.md").read_text()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--format", "pdf"], "--format: a comma-separated list of c, onnx, got 'pdf'"),
        (["--model", "nope"], "is not a directory"),
    ],
)
def test_bad_input_is_one_line(tmp_path, capsys, argv, message):
    base = ["export", "--model", str(MODELS / "linear-motor"), "--out", str(tmp_path / "o")]
    for i in range(0, len(argv), 2):
        flag = argv[i]
        j = base.index(flag) if flag in base else None
        if j is None:
            base += argv[i : i + 2]
        else:
            base[j + 1] = argv[i + 1]
    assert main(base) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err


@pytest.mark.parametrize("name", ["friction-table", "hsm2", "linear-motor"])
def test_every_shipped_agent_exports_in_both_forms(tmp_path, name):
    pytest.importorskip("onnx")
    out = tmp_path / name
    assert main(["export", "--model", str(MODELS / name), "--out", str(out)]) == 0
    assert {p.name for p in out.iterdir()} >= {"residual.c", "residual.h", "residual.onnx",
                                               "README.md"}  # fmt: skip


def test_an_agent_of_a_plant_file_that_is_gone_is_refused_naming_the_option(tmp_path, capsys):
    import json
    import shutil

    model = tmp_path / "m"
    shutil.copytree(MODELS / "friction-table", model)
    meta = json.loads((model / "agent.json").read_text())
    meta.update(plant="identified", plant_file="plant.json")
    (model / "agent.json").write_text(json.dumps(meta))
    cfg = json.loads((model / "config.json").read_text())
    cfg["plant"] = str(tmp_path / "gone" / "plant.json")
    (model / "config.json").write_text(json.dumps(cfg))
    assert main(["export", "--model", str(model), "--out", str(tmp_path / "o"),
                 "--format", "c"]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert "trained on a plant file (plant.json, plant 'identified')" in err
    assert "give it with --plant" in err and "\n" not in err


def test_onnx_alone_writes_no_c_and_still_documents_the_interface(tmp_path):
    pytest.importorskip("onnx")
    out = tmp_path / "o"
    assert main(["export", "--model", str(MODELS / "linear-motor"), "--out", str(out),
                 "--format", "onnx"]) == 0  # fmt: skip
    assert {p.name for p in out.iterdir()} == {"residual.onnx", "README.md"}
    assert "| `encoder_position` | m | 3 |" in (out / "README.md").read_text()
