"""The chain file: emcee's HDF layout plus hmid's checkpoints (random state, counts, digest).

Each checkpoint is one attribute with a new name, written after the rows it covers, so an
interrupted write can never pair a random state with the wrong iteration. It carries a chained
SHA-256 over every block of rows written so far (``h_k = sha256(h_{k-1} || sha256(block_k))``):
resuming verifies the whole stored chain, not only its last row, and a chain that does not match
is sampled afresh with a one-line note. A file lock is held while a chain is written: a second
writer waits for the first instead of deleting its file.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import emcee
import h5py
import numpy as np

from hmid.errors import HmidWarning
from hmid.files import held
from hmid.models.sls._errors import SamplerError

#: the fix a chain-file error offers (the file is a cache: deleting it only costs sampling time)
FIX = "delete it to sample afresh (hmid run --force does)"
_KEEP_CHECKPOINTS = 2  # the newest checkpoints kept; older ones are deleted


def _state_to_json(state) -> dict[str, Any]:
    _, keys, pos, has_gauss, cached = state
    return {
        "keys": np.asarray(keys, "<u4").tobytes().hex(),
        "pos": int(pos),
        "has_gauss": int(has_gauss),
        "cached_gaussian": float(cached),
    }


def state_from_json(data: Mapping[str, Any]) -> tuple:
    """numpy's MT19937 state back from the chain file's JSON (emcee resumes with it)."""
    keys = np.frombuffer(bytes.fromhex(data["keys"]), dtype="<u4").astype(np.uint32)
    return ("MT19937", keys, data["pos"], data["has_gauss"], data["cached_gaussian"])


def _chained(previous: str, chain: np.ndarray, logp: np.ndarray) -> str:
    """The digest after one more block of rows."""
    block = hashlib.sha256(np.ascontiguousarray(chain, "<f8").tobytes())
    block.update(np.ascontiguousarray(logp, "<f8").tobytes())
    return hashlib.sha256(bytes.fromhex(previous) + block.digest()).hexdigest()


_ORIGIN = "00" * 32  # the digest of no rows


class ChainStore:
    """The chain file: emcee's HDFBackend layout in ``mcmc``, hmid's metadata in ``hmid``."""

    def __init__(self, path: Path, meta: dict[str, Any], n_walkers: int, dim: int):
        self.path, self.meta, self.shape = path, meta, (n_walkers, dim)
        self.blocks: list[int] = []  # the rows each written block ends at
        self.digest = _ORIGIN

    def lock(self):
        """Hold ``<file>.lock`` while sampling: a second writer waits (and says so)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        return held(
            f"{self.path}.lock",
            f"{self.path}: another run is sampling this chain; waiting for it to finish",
        )

    def _open(self, mode: str) -> h5py.File:
        try:
            return h5py.File(self.path, mode)
        except OSError as exc:
            raise SamplerError(
                f"{self.path}: cannot open as an HDF5 chain file ({exc}); {FIX}"
            ) from exc

    def prepare(self, fresh: bool = False) -> dict[str, Any] | None:
        """Refuse a foreign or mismatching file; return its newest valid checkpoint, if any
        (none with ``fresh``: the chain is then sampled anew)."""
        if fresh:
            self.path.unlink(missing_ok=True)  # under the lock: no other writer holds it
        if not self.path.exists():
            return None
        with self._open("a") as f:
            foreign = sorted(set(f) - {"mcmc", "hmid"})
            try:
                stored = json.loads(f["hmid"].attrs["meta"])
            except (KeyError, ValueError, TypeError):
                stored = None
            if foreign or (stored is None and "mcmc" in f):
                raise SamplerError(
                    f"{self.path}: not a chain file written by hmid's sampler; {FIX}"
                )
            if stored is None:
                return None
            if stored.get("format") != self.meta["format"]:
                return None  # written by another hmid version: sampled afresh
            if stored != self.meta:
                diff = [k for k in self.meta if stored.get(k) != self.meta[k]]
                raise SamplerError(
                    f"{self.path}: holds a chain sampled with a different configuration (differs "
                    f"in {', '.join(diff)}); {FIX}"
                )
            return self._newest_checkpoint(f)

    def _newest_checkpoint(self, f: h5py.File) -> dict[str, Any] | None:
        """The newest checkpoint that parses and whose digest matches every row it covers;
        newer ones (half-written when a run was interrupted, or not matching) are deleted."""
        group, chain, logp = f["hmid"], f["mcmc/chain"], f["mcmc/log_prob"]
        for key in sorted((k for k in group.attrs if k.startswith("ckpt_")), reverse=True):
            try:
                ckpt = json.loads(group.attrs[key])
                n, blocks = ckpt["iteration"], ckpt["blocks"]
                if 1 <= n <= len(chain) and blocks and blocks[-1] == n:
                    if self._verify(chain, logp, blocks) == ckpt["digest"]:
                        self.blocks, self.digest = list(blocks), ckpt["digest"]
                        return ckpt
                    warnings.warn(
                        f"{self.path}: the stored chain does not match its checksum (rows "
                        f"altered or damaged); not resumed from step {n}",
                        HmidWarning,
                        stacklevel=5,
                    )
            except (KeyError, ValueError, TypeError):
                pass
            del group.attrs[key]
        return None

    @staticmethod
    def _verify(chain, logp, blocks: list[int]) -> str:
        digest, start = _ORIGIN, 0
        for end in blocks:
            digest = _chained(digest, chain[start:end], logp[start:end])
            start = end
        return digest

    def read(self, ckpt: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
        """The rows the checkpoint covers (verified by :meth:`prepare`)."""
        n = ckpt["iteration"]
        with self._open("r") as f:
            return f["mcmc/chain"][:n], f["mcmc/log_prob"][:n]

    def initialise(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._open("a") as f:
            for name in ("hmid", "mcmc"):
                if name in f:
                    del f[name]
            group = f.create_group("hmid")
            group.create_dataset(
                "tau_history", (0, self.shape[1] + 1), maxshape=(None, None), dtype="f8"
            )
            group.attrs["meta"] = json.dumps(self.meta)
        emcee.backends.HDFBackend(str(self.path)).reset(*self.shape)
        self.blocks, self.digest = [], _ORIGIN

    def save(self, backend, state, saved, n, n_nan, history, accepted) -> None:
        """Write rows ``saved:n``, then the checkpoint, then emcee's own bookkeeping."""
        chain, logp = backend.chain[:n], backend.log_prob[:n]
        if (self.blocks[-1] if self.blocks else 0) != saved:  # a bug, not bad input
            raise AssertionError(f"{self.path}: rows {saved}:{n} do not follow the saved ones")
        self.digest = _chained(self.digest, chain[saved:n], logp[saved:n])
        self.blocks.append(n)
        ckpt = {
            "iteration": n,
            "blocks": self.blocks,
            "digest": self.digest,
            "random_state": _state_to_json(state.random_state),
            "accepted": accepted.tolist(),
            "n_nan": n_nan,
            "n_tau": len(history),
        }
        with self._open("a") as f:
            g, group = f["mcmc"], f["hmid"]
            for name, data in (("chain", chain), ("log_prob", logp)):
                g[name].resize(n, axis=0)
                g[name][saved:n] = data[saved:n]
            group["tau_history"].resize((len(history), self.shape[1] + 1))
            if history:
                group["tau_history"][...] = np.asarray(history)
            group.attrs[f"ckpt_{n:012d}"] = json.dumps(ckpt)
            g["accepted"][...] = accepted
            g.attrs["iteration"] = n
            for i, value in enumerate(state.random_state):
                g.attrs[f"random_state_{i}"] = value
            old = sorted(k for k in group.attrs if k.startswith("ckpt_"))[:-_KEEP_CHECKPOINTS]
            for key in old:
                del group.attrs[key]
