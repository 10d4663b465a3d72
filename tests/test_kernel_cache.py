"""Where the compiled kernels are cached: one folder per digest of the kernel sources, shared
by every checkout on the machine; numba's default in-tree folders lose stale caches."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from contour_env import kernel_cache


def _tree(tmp_path):
    root = tmp_path / "pkg"
    for rel in kernel_cache.KERNEL_SOURCES:
        src = kernel_cache.PACKAGE / rel
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(src, root / rel)
    return root


def _caches(root):
    files = []
    for rel in ("env/kernel.py", "plants/kernel.py"):
        d = (root / rel).parent / "__pycache__"
        d.mkdir(exist_ok=True)
        for name in ("kernel.env_step-1.py311.nbi", "kernel.env_step-1.py311.1.nbc"):
            (d / name).write_text("x")
            files.append(d / name)
    keep = root / "env" / "__pycache__" / "kernel.cpython-311.pyc"
    keep.write_text("bytecode")
    return files, keep


def test_caches_are_kept_while_the_sources_are_unchanged_and_dropped_after_an_edit(tmp_path):
    root = _tree(tmp_path)
    files, keep = _caches(root)
    # first import: no stamp yet, so the caches cannot be trusted
    assert sorted(kernel_cache.refresh_stale_caches(root)) == sorted(files)
    files, keep = _caches(root)
    assert kernel_cache.refresh_stale_caches(root) == []
    assert all(f.exists() for f in files)
    # an edit of an inlined module (not of the caller) invalidates every cache
    with open(root / "plants" / "kernel.py", "a") as fh:
        fh.write("\n# edited\n")
    assert sorted(kernel_cache.refresh_stale_caches(root)) == sorted(files)
    assert not any(f.exists() for f in files) and keep.exists()
    assert kernel_cache.refresh_stale_caches(root) == []


def test_every_module_with_numba_code_is_a_kernel_source():
    # a kernel module missing from the list would run against an old compiled kernel
    assert kernel_cache.KERNEL_SOURCES == kernel_cache.kernel_sources()


def test_a_cold_cache_is_announced_before_a_command_and_not_for_a_listing(tmp_path, capsys):
    from contour_env import kernel_cache
    from contour_env.app.cli import _cold_cache_note

    class Args:
        command = "compare"

    (tmp_path / "env" / "__pycache__").mkdir(parents=True)
    assert kernel_cache.cache_is_cold(tmp_path)
    (tmp_path / "env" / "__pycache__" / "kernel.step-1.py311.nbi").write_text("")
    assert not kernel_cache.cache_is_cold(tmp_path)
    import unittest.mock as mock

    with mock.patch.object(kernel_cache, "cache_is_cold", return_value=True):
        _cold_cache_note(Args())
        Args.command = "cases"
        _cold_cache_note(Args())
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [kernel_cache.COLD_NOTE]


def test_the_digest_locator_is_installed_and_an_edit_gives_a_new_folder(tmp_path):
    assert kernel_cache.locator_installed()
    assert os.environ["NUMBA_CACHE_LOCATOR_CLASSES"].startswith(kernel_cache.LOCATOR)
    root = _tree(tmp_path)
    before = kernel_cache.sources_digest(root)
    assert before == kernel_cache.sources_digest(kernel_cache.PACKAGE)  # any checkout: one key
    with open(root / "noise.py", "a") as fh:
        fh.write("\n# edited\n")
    assert kernel_cache.sources_digest(root) != before


def test_the_locator_maps_package_files_into_the_digest_folder_and_others_to_numba():
    from contour_env import noise

    locator_cls = kernel_cache.DigestCacheLocator
    loc = locator_cls.from_function(noise.uniform01.py_func, noise.__file__)
    env_dir, compiled_dir = kernel_cache.digest_folders()
    assert Path(loc.get_cache_path()) == env_dir
    from contour_env.plants import kernel as plant_kernel

    loc = locator_cls.from_function(plant_kernel.axis_step.py_func, plant_kernel.__file__)
    assert Path(loc.get_cache_path()) == env_dir / "plants"
    from agents.compiled import laws

    fn = next(v for v in vars(laws).values() if hasattr(v, "py_func"))
    loc = locator_cls.from_function(fn.py_func, laws.__file__)
    assert Path(loc.get_cache_path()) == compiled_dir
    # a function of another package is left to numba's own locators
    assert (
        locator_cls.from_function(
            test_the_locator_maps_package_files_into_the_digest_folder_and_others_to_numba, __file__
        )
        is None
    )


def test_the_source_stamp_is_the_content_not_the_checkout_time(tmp_path):
    # two clones hold the same bytes with different paths and times: one stamp
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text("x = 1\n")
    b.write_text("x = 1\n")
    os.utime(b, (1e9, 1e9))
    from contour_env import noise

    locator_cls = kernel_cache.DigestCacheLocator
    fn = noise.uniform01.py_func
    sa = locator_cls(fn, str(a), tmp_path).get_source_stamp()
    assert sa == locator_cls(fn, str(b), tmp_path).get_source_stamp()
    b.write_text("x = 2\n")
    assert sa != locator_cls(fn, str(b), tmp_path).get_source_stamp()


CALL = (
    "import contour_env.noise as n, json, os; v = n.uniform01(1, 2, 0, 0); "
    "print(json.dumps([v, n.uniform01.stats.cache_hits.most_common(1)[0][1] "
    "if n.uniform01.stats.cache_hits else 0]))"
)


def _run(code, cwd, env):
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.strip().splitlines()[-1]


def test_a_second_checkout_loads_the_first_ones_kernels(tmp_path):
    """End to end: a kernel compiled by one copy of the package is loaded, not compiled, by a
    copy at another path (a fresh clone), and the folder is the digest's."""
    import json

    repo = kernel_cache.PACKAGE.parent
    ignore = shutil.ignore_patterns("__pycache__")
    clones = []
    for name in ("clone1", "clone2"):
        dst = tmp_path / name
        shutil.copytree(repo / "contour_env", dst / "contour_env", ignore=ignore)
        clones.append(dst)
    cache = tmp_path / "kernels"
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    env.update(CONTOUR_ENV_KERNEL_CACHE=str(cache), PYTHONPATH="")
    first = json.loads(_run(CALL, clones[0], env))
    folders = sorted(p.name for p in cache.iterdir())
    assert [f.split("-")[0] for f in folders] == ["env"], folders
    assert folders[0].startswith(f"env-{kernel_cache.sources_digest()[:16]}-")
    assert list((cache / folders[0]).glob("noise.uniform01-*.nbi"))
    second = json.loads(_run(CALL, clones[1], env))
    assert second[0] == first[0]
    assert second[1] == 1, "the second checkout compiled the kernel again"
    # the user's own NUMBA_CACHE_DIR wins: the package leaves numba's locators alone
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba_own")
    out = _run(
        "import contour_env, os; print(os.environ.get('NUMBA_CACHE_LOCATOR_CLASSES'))",
        clones[1],
        env,
    )
    assert out == "None"


def test_no_locator_when_the_user_chose_numbas(monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_LOCATOR_CLASSES", "InTreeCacheLocator")
    assert kernel_cache.install_locator() is False
    assert os.environ["NUMBA_CACHE_LOCATOR_CLASSES"] == "InTreeCacheLocator"


def test_an_unwritable_cache_root_keeps_numbas_folders_and_their_invalidation(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    env["CONTOUR_ENV_KERNEL_CACHE"] = str(blocker / "kernels")
    code = (
        "import contour_env, os\n"
        "from contour_env import kernel_cache as k\n"
        "print(os.environ.get('NUMBA_CACHE_LOCATOR_CLASSES'), k.locator_installed())"
    )
    assert _run(code, kernel_cache.PACKAGE.parent, env) == "None False"
