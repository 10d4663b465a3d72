"""Stale numba caches are dropped when any kernel source changes."""

import shutil

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
