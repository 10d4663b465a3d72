"""Fingerprints of every named case × controller (the benchmark's nominal runs, learning
controllers too) and the quick suite's robustness and ILC runs: the sha256 of each run's
metrics and figure trace as JSON at full float precision. Two versions of the code give the
same results to the bit on these runs when their fingerprints match: the check of a
refactoring (run it on the commit before, then on the change, ``--against`` the first file;
exit 1 and the runs that differ when any does, or when a run of the earlier file is no longer
made; runs added since are listed as new, not as differing).

    python scripts/fingerprint_runs.py --out FILE [--against FILE] [--only SUBSTRING]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time

try:
    from contour_env.app.benchmark import suite as S
    from contour_env.app.benchmark.runs import execute
except ImportError:
    from contour_env.benchmark import suite as S  # the layout before contour_env.app
    from contour_env.benchmark.runs import execute


def specs(only: str | None = None):
    runs = S._unique(S._all_nominal(learning=True) + list(S.quick_suite().runs))
    return [r for r in runs if only is None or only in _key(r)]


def _key(spec) -> str:
    key = spec.key()
    return key if isinstance(key, str) else repr(key)


def fingerprint(spec) -> dict:
    r = execute(spec.to_dict())
    body = {"metrics": r.get("metrics"), "trace": r.get("trace"), "error": r.get("error")}
    blob = json.dumps(body, sort_keys=True, default=repr).encode()
    metrics = r.get("metrics") or {}
    return {
        "sha256": hashlib.sha256(blob).hexdigest(),
        "error": r.get("error"),
        "rms_contour_error_um": metrics.get("rms_contour_error_um"),
    }


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--against", help="a file of an earlier run: compare, exit 1 on a change")
    ap.add_argument("--only", help="only the runs whose key contains this text")
    a = ap.parse_args(argv)
    out, t0 = {}, time.perf_counter()
    for s in specs(a.only):
        out[_key(s)] = fingerprint(s)
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
    os.replace(tmp, a.out)
    print(f"{len(out)} runs in {time.perf_counter() - t0:.0f} s -> {a.out}")
    if a.against:
        with open(a.against) as f:
            ref = json.load(f)
        if a.only:
            ref = {k: v for k, v in ref.items() if a.only in k}
        common = sorted(set(ref) & set(out))
        diff = [k for k in common if ref[k].get("sha256") != out[k].get("sha256")]
        new, gone = sorted(set(out) - set(ref)), sorted(set(ref) - set(out))
        print(f"differ: {len(diff)} of {len(common)} runs in both files")
        for k in diff:
            print("  ", k, ref[k], out[k])
        if new:  # runs added since the earlier file: nothing to compare them with
            print(f"new: {len(new)} (not in {a.against})")
            for k in new:
                print("  ", k)
        if gone:  # a run that is no longer made is a change
            print(f"missing: {len(gone)} (in {a.against}, not run now)")
            for k in gone:
                print("  ", k)
        return 1 if diff or gone else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
