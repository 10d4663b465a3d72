"""Start-up cost of the command line: the heavy optional imports stay out of the path of a
command that does not use them (scipy.signal: the ILC Q-filter; matplotlib: plots;
scipy.interpolate: spline paths). Checked in a fresh interpreter, by the modules loaded."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("scipy.signal", "matplotlib.pyplot", "scipy.interpolate")


def _loaded_after(code: str) -> dict:
    report = f"print(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))"
    probe = f"import json, sys\n{code}\n{report}"
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_compare_imports_no_filter_design_plotting_or_splines():
    loaded = _loaded_after("import agents.compare, contour_env.app.cli")
    assert loaded == {m: False for m in HEAVY}


def test_the_lazy_imports_still_work_where_used():
    # the Q-filter designs and runs its Butterworth filter; a spline path is built
    code = (
        "import numpy as np\n"
        "from agents.qfilter import ZeroPhaseLowPass\n"
        "q = ZeroPhaseLowPass(50.0, 1e-3)\n"
        "y = q(np.ones((1, 200)))\n"
        "assert np.allclose(y, 1.0), y\n"
        "from contour_env.paths.builders import spline\n"
        "p = spline([[0, 0], [0.01, 0.02], [0.03, 0.01], [0.05, 0.0]])\n"
    )
    loaded = _loaded_after(code)
    assert loaded["scipy.signal"] and loaded["scipy.interpolate"]
