"""A model file evaluated with numpy alone (no hmid import): the reference that the model file
format is complete. Input: the file (parsed JSON) and the signals as the file describes them,
per row: t, segment, the smoothed channels, v and a, and ``raw:<c>`` before smoothing."""

import numpy as np


def moving_average(y, n, passes):
    """Centred moving average of n (odd) samples with shrinking symmetric edges, ``passes``
    times."""
    h = (n - 1) // 2
    for _ in range(passes):
        c = np.concatenate([[0.0], np.cumsum(y)])
        out = np.empty_like(y)
        i = np.arange(len(y))
        half = np.minimum(np.minimum(i, len(y) - 1 - i), h)
        out = (c[i + half + 1] - c[i - half]) / (2 * half + 1)
        y = out
    return y


def smooth(values, frame, document):
    spec = document["denoise"]["smoother"]
    out = np.empty(len(values))
    for s in np.unique(frame["segment"]):
        rows = np.flatnonzero(frame["segment"] == s)
        dt = np.median(np.diff(frame["t"][rows]))
        n = int(np.floor(spec["window_s"] / dt + 0.5))
        n += n % 2 == 0
        out[rows] = moving_average(values[rows], n, spec["passes"])
    return out


def memory(frame, channel, tau):
    """g_tau: dq/dt = -q/tau + dx/dt, x piecewise linear, from rest at each segment start."""
    t, x, seg = frame["t"], frame[channel], frame["segment"]
    q = np.zeros(len(t))
    for k in range(1, len(t)):
        if seg[k] != seg[k - 1]:
            continue
        dt = t[k] - t[k - 1]
        decay = np.expm1(-dt / tau)
        q[k] = (1 + decay) * q[k - 1] - tau * decay * (x[k] - x[k - 1]) / dt
    return q


def powers(text):
    out = {}
    for factor in text.split("*"):
        name, _, p = factor.partition("^")
        out[name] = out.get(name, 0) + int(p or 1)
    return out


def column(term, frame, document):
    kind = term["kind"]
    logged = [c for c in document["rig"]["channels"]]
    if kind == "constant":
        values = np.ones(len(frame["t"]))
    elif kind == "channel":
        p = powers(term["channel"])
        if sum(p.values()) == 1 or not all(c in logged for c in p):
            values = np.prod([frame[c] ** k for c, k in p.items()], axis=0)
        else:
            values = smooth(np.prod([frame["raw:" + c] ** k for c, k in p.items()], axis=0),
                            frame, document)  # fmt: skip
    elif kind == "coulomb":
        values = smooth(np.sign(frame["raw:" + term["channel"]]), frame, document)
    elif kind == "smooth_coulomb":
        values = smooth(np.tanh(frame["raw:" + term["channel"]] / term["scale"]), frame, document)
    elif kind == "memory":
        values = memory(frame, term["channel"], term["tau"])
    else:
        raise NotImplementedError(kind)
    return term["sign"] * values


def predict(document, frame):
    """(target, explained): the model's terms, and with the known free-fall friction added."""
    target = sum(
        c * column(term, frame, document)
        for term, c in zip(document["terms"], document["coefficients"]["values"], strict=True)
    )
    known = np.zeros(len(frame["t"]))
    law = document["known"]["free_fall_friction"]
    for term in document["rig"]["balance"]:
        if term.get("from") == "free_fall":
            v = frame["raw:" + term.get("channel", "v")]
            known += term["sign"] * smooth((law["Fc"] + law["b"] * np.abs(v)) * np.sign(v),
                                           frame, document)  # fmt: skip
    return target, target + known
