"""The chain file: emcee's HDF layout plus hmid's checkpoints (random state, counts, checksum).

Each checkpoint is one attribute with a new name, written after the rows it covers, so an
interrupted write can never pair a random state with the wrong iteration.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import emcee
import h5py
import numpy as np

from hmid.models.sls._errors import SamplerError

_KEEP_CHECKPOINTS = 2  # the newest checkpoints kept; older ones are deleted


def _state_to_json(state) -> dict[str, Any]:
    _, keys, pos, has_gauss, cached = state
    return {
        "keys": np.asarray(keys, "<u4").tobytes().hex(),
        "pos": int(pos),
        "has_gauss": int(has_gauss),
        "cached_gaussian": float(cached),
    }


def _state_from_json(data: Mapping[str, Any]) -> tuple:
    keys = np.frombuffer(bytes.fromhex(data["keys"]), dtype="<u4").astype(np.uint32)
    return ("MT19937", keys, data["pos"], data["has_gauss"], data["cached_gaussian"])


def _checksum(chain: np.ndarray, logp: np.ndarray) -> str:
    data = (
        np.ascontiguousarray(chain, "<f8").tobytes() + np.ascontiguousarray(logp, "<f8").tobytes()
    )
    return hashlib.sha256(data).hexdigest()[:16]


class _Store:
    """The chain file: emcee's HDFBackend layout in ``mcmc``, hmid's metadata in ``hmid``."""

    def __init__(self, path: Path, meta: dict[str, Any], n_walkers: int, dim: int):
        self.path, self.meta, self.shape = path, meta, (n_walkers, dim)

    def _open(self, mode: str) -> h5py.File:
        try:
            return h5py.File(self.path, mode)
        except OSError as exc:
            raise SamplerError(
                f"{self.path}: cannot open as an HDF5 chain file ({exc}); delete it or choose "
                f"another backend_path"
            ) from exc

    def prepare(self) -> dict[str, Any] | None:
        """Refuse a foreign or mismatching file; return its newest valid checkpoint, if any."""
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
                    f"{self.path}: not a chain file written by hmid's sampler; choose another "
                    f"backend_path"
                )
            if stored is None:
                return None
            if stored != self.meta:
                diff = [k for k in self.meta if stored.get(k) != self.meta[k]]
                raise SamplerError(
                    f"{self.path}: holds a chain sampled with a different configuration (differs "
                    f"in {', '.join(diff)}); delete the file or choose another backend_path"
                )
            return self._newest_checkpoint(f)

    def _newest_checkpoint(self, f: h5py.File) -> dict[str, Any] | None:
        """The newest checkpoint that parses and matches the rows it covers; newer ones
        (half-written when a run was interrupted) are deleted."""
        group, chain, logp = f["hmid"], f["mcmc/chain"], f["mcmc/log_prob"]
        for key in sorted((k for k in group.attrs if k.startswith("ckpt_")), reverse=True):
            try:
                ckpt = json.loads(group.attrs[key])
                n = ckpt["iteration"]
                if (
                    1 <= n <= len(chain)
                    and ckpt["n_tau"] <= len(group["tau_history"])
                    and _checksum(chain[n - 1], logp[n - 1]) == ckpt["checksum"]
                ):
                    return ckpt
            except (KeyError, ValueError, TypeError):
                pass
            del group.attrs[key]
        return None

    def read(self, ckpt: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, list[list[float]]]:
        n = ckpt["iteration"]
        with self._open("r") as f:
            history = f["hmid/tau_history"][: ckpt["n_tau"]].tolist()
            return f["mcmc/chain"][:n], f["mcmc/log_prob"][:n], history

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

    def save(self, backend, state, saved, n, n_nan, tau, tau_prior, tau_ref, history) -> None:
        """Write rows ``saved:n``, then the checkpoint, then emcee's own bookkeeping."""
        chain, logp = backend.chain[:n], backend.log_prob[:n]
        ckpt = {
            "iteration": n,
            "checksum": _checksum(chain[n - 1], logp[n - 1]),
            "random_state": _state_to_json(state.random_state),
            "accepted": backend.accepted.tolist(),
            "n_nan": n_nan,
            "n_tau": len(history),
            "tau": None if tau is None else tau.tolist(),
            "tau_prior": None if tau_prior is None else tau_prior.tolist(),
            "tau_ref": None if tau_ref is None else tau_ref.tolist(),
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
            g["accepted"][...] = backend.accepted
            g.attrs["iteration"] = n
            for i, value in enumerate(state.random_state):
                g.attrs[f"random_state_{i}"] = value
            old = sorted(k for k in group.attrs if k.startswith("ckpt_"))[:-_KEEP_CHECKPOINTS]
            for key in old:
                del group.attrs[key]
