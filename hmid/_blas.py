"""BLAS threading for thin products: one thread, its libraries found once."""

from __future__ import annotations

from functools import cache

from threadpoolctl import ThreadpoolController


@cache
def _controller():

    return ThreadpoolController()  # finding the loaded libraries costs ~3 ms: once


def one_blas_thread():
    """A context in which BLAS runs one thread (``threadpoolctl``, its libraries found once)."""
    return _controller().limit(limits=1, user_api="blas")
