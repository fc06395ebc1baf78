"""Numba's cache goes to the user's cache folder unless NUMBA_CACHE_DIR is set."""

import importlib
import os
import sys

import pytest

import trackdyn


@pytest.mark.skipif(sys.platform in ("win32", "darwin"), reason="the XDG rule is for Linux")
def test_the_numba_cache_defaults_to_the_user_cache_folder(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    importlib.reload(trackdyn)
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "trackdyn" / "numba")


def test_a_numba_cache_folder_the_user_set_is_kept(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    importlib.reload(trackdyn)
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")
