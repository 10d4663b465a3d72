"""The sim-to-real chain, end to end, as a user with a real machine would run it (issue 50):

1. the "machine": the catalogue's friction-table, realistic effects and 0.1 µm encoder noise,
   which the rest of the chain never reads (only its trace and, at the end, its runs);
2. ``excite`` and the trace the machine records (its response with the noise);
3. ``identify`` (plant.json), its parts' ranges set to the machine's parts (the friction
   table's training ranges: what a user edits ``travel``/``feed_range``/``max_acceleration``
   to), then ``tune`` (PD's ω and CCC's coupling for the identified plant);
4. ``train --plant plant.json`` with the recipe of the shipped agents (``scripts/
   train_agents.py``: teacher, SAC, the time budget, keep-best, envelope), base CCC;
5. ``export`` (the C law);
6. the exported C law run on the **machine** on top of CCC with the identified plant's tuned
   gains, over the held-out suite (``agents/rl/scorecard.py``'s programs of the plant),
   against that CCC alone.

Also measured: the same chain with the identified plant deliberately off (friction +20 %,
mass −10 %: ``perturbed``), and an agent trained on the machine itself (``machine``, the
upper bound; its base CCC with the named plant's gains).

    python scripts/sim_to_real.py --out out/s2r [--budget 600] [--jobs 2] [--seed 0]
        [--variants identified,perturbed,machine]

Writes ``OUT/sim_to_real.json`` (per variant and program: base and law RMS/max contour error
and their ratios; the identification's figures) and prints a table. Training runs are the
long part (``--budget`` seconds each; ``--jobs`` of them at a time).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

MACHINE = "friction-table"
NOISE_M = 1e-7
VARIANTS = ("identified", "perturbed", "machine")
PERTURB = {"coulomb": 1.2, "static": 1.2, "mass": 0.9}


def identify_machine(out: Path, seed: int) -> dict:
    """Steps 2-3: the plant files of the identified and the perturbed model, tuned."""
    from agents.rl.families import PLANT_RANGES
    from contour_env.app.cli import main as cli
    from contour_env.excite import excite
    from contour_env.identify import identify, trace_from_arrays, write_plant

    exc = excite(MACHINE, noise_m=NOISE_M, seed=seed)
    trace = trace_from_arrays(exc.time_s, exc.simulated_command, exc.simulated_position,
                              exc.axes, source="machine.csv")  # fmt: skip
    ident = identify(trace)
    files = {}
    r = PLANT_RANGES[MACHINE]
    for name in ("identified", "perturbed"):
        path = out / f"{name}.json"
        write_plant(path, ident, name=name)
        data = json.loads(path.read_text())
        data.update(travel=r.travel_m, feed_range=list(r.feed_m_s),
                    max_acceleration=r.max_accel_m_s2)  # fmt: skip
        if name == "perturbed":
            for key, f in PERTURB.items():
                data[key] = [v * f for v in data[key]]
        path.write_text(json.dumps(data, indent=2) + "\n")
        assert cli(["tune", "--plant", str(path), "--out", str(path)]) == 0
        files[name] = str(path)
    fits = {f.axis: {k: f.values[k] for k in ("mass", "viscous", "coulomb", "static")}
            for f in ident.axes}  # fmt: skip
    return {"files": files, "fits": fits, "poor_fit": ident.poor_fit, "warnings": ident.warnings}


def base_spec(plant_file: str | None) -> str:
    """CCC with the plant file's tuned gains (the controller the machine runs), or the named
    plant's CCC."""
    if plant_file is None:
        return "ccc"
    g = json.loads(Path(plant_file).read_text()).get("controller_gains") or {}
    w = g.get("pd", {}).get("bandwidth_rad_s")
    c = g.get("ccc", {})
    parts = [f"w={w!r}"] if w else []
    parts += [f"{k.lower().replace('_', '')}={v!r}" for k, v in c.items()]
    return "ccc" + "".join(f":{p}" for p in parts)


def train_variant(args) -> str:
    """Step 4 for one variant: the recipe on its plant (file); the run folder."""
    name, plant, out, budget, seed = args
    sys.path.insert(0, str(ROOT / "scripts"))
    from train_agents import SHIPPED

    from agents.rl import TrainConfig, train

    recipe = dict(SHIPPED[MACHINE], plant=plant, time_budget_s=float(budget), seed=seed)
    run = Path(out) / f"run_{name}"
    train(TrainConfig(**recipe), run, progress=False, log=lambda s: None)
    return str(run)


def score_variant(run: str, base: str, out: Path) -> list[dict]:
    """Steps 5-6: export the C law and run it on the machine over the held-out suite."""
    import gymnasium as gym

    from agents.export import write_c
    from agents.export.c_runner import CLaw, CLawController
    from agents.registry import make_controller
    from agents.rl.scorecard import heldout_programs, program_label
    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    iface = write_c(run, out / f"export_{Path(run).name}")
    law = CLaw(out / f"export_{Path(run).name}", iface)
    rows = []
    for prog in heldout_programs(2, MACHINE):
        kw = dict(plant=MACHINE, path=str(prog), measurement_noise_std_m=NOISE_M)
        b = evaluate(gym.make(ENV_ID, **kw), make_controller(base))
        a = evaluate(gym.make(ENV_ID, **kw), CLawController(law, base))
        row = {"program": program_label(prog), "base": base, "completed": bool(a["completed"])}
        for key, short in (("rms_contour_error_um", "rms"), ("max_contour_error_um", "max")):
            row[f"base_{short}_um"], row[f"law_{short}_um"] = b[key], a[key]
            row[f"{short}_ratio"] = a[key] / b[key] if b[key] else math.nan
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> dict:
    rms = [r["rms_ratio"] for r in rows]
    mx = [r["max_ratio"] for r in rows]
    return {
        "programs": len(rows),
        "mean_rms_ratio": sum(rms) / len(rms),
        "worst_rms_ratio": max(rms),
        "mean_max_ratio": sum(mx) / len(mx),
        "worst_max_ratio": max(mx),
        "programs_worse": sum(1 for a, b in zip(rms, mx, strict=True) if a > 1.0 or b > 1.0),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/s2r")
    ap.add_argument("--budget", type=float, default=600.0, help="training seconds per agent")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--jobs", type=int, default=2, help="trainings at a time")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        ap.error(f"--variants: unknown {bad}; allowed: {', '.join(VARIANTS)}")
    ident = identify_machine(out, args.seed)
    print(f"identified: {json.dumps(ident['fits'])}; poor fit: {ident['poor_fit'] or 'none'}")
    plants = {"identified": ident["files"]["identified"],
              "perturbed": ident["files"]["perturbed"], "machine": MACHINE}  # fmt: skip
    jobs = [(v, plants[v], str(out), args.budget, args.seed) for v in variants]
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        runs = dict(zip(variants, pool.map(train_variant, jobs), strict=True))
    result = {"machine": MACHINE, "noise_m": NOISE_M, "budget_s": args.budget,
              "identification": ident, "variants": {}}  # fmt: skip
    for v in variants:
        meta = json.loads((Path(runs[v]) / "agent.json").read_text())
        base = base_spec(None if v == "machine" else plants[v])
        rows = score_variant(runs[v], base, out)
        result["variants"][v] = {"run": runs[v], "kept": meta.get("kept"), "base": base,
                                 "rows": rows, "summary": summary(rows)}  # fmt: skip
        s = result["variants"][v]["summary"]
        print(
            f"{v}: kept {meta.get('kept')}; held-out mean RMS {s['mean_rms_ratio']:.3f}x, "
            f"worst {s['worst_rms_ratio']:.3f}x; max mean {s['mean_max_ratio']:.3f}x, worst "
            f"{s['worst_max_ratio']:.3f}x; {s['programs_worse']} of {s['programs']} worse"
        )
    from contour_env.io import atomic_write_json

    atomic_write_json(out / "sim_to_real.json", result)
    print(f"wrote {out / 'sim_to_real.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
