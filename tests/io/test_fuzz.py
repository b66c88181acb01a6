"""Property tests: malformed tables end in hmid's own errors, well-formed ones load exactly."""

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from hmid.errors import HmidError, HmidWarning
from hmid.io import ChannelSpec, ColumnMap, Log, log_from_frame, read_log

FUZZ = settings(max_examples=150, deadline=None, database=None)

NAMED = ColumnMap(
    channels={
        "t": ChannelSpec(column="time", unit="ms"),
        "P": ChannelSpec(column="p", unit="kPa"),
        "x": ChannelSpec(column="pos", unit="mm", adc_bits=8, scale=0.5),
    }
)
POSITIONAL = ColumnMap(
    channels={
        "t": ChannelSpec(column=0, unit="ms"),
        "P": ChannelSpec(column=1, unit="kPa", range=(-1e6, 1e6)),
        "x": ChannelSpec(column=2, unit="mm"),
    },
    header=False,
)
SEPARATORS = [",", "\t", ";", "|", " "]
LABELS = ["time", "p", "pos", "junk"]

bad_cells = st.one_of(
    st.text(max_size=6),
    st.sampled_from(["", "NaN", "inf", "-inf", "NA", "1e400", "0x1F", "1,5", '"', "#", "1 2"]),
    st.floats().map(repr),
    st.integers(-(10**25), 10**25).map(str),
)
good_cells = st.floats(-1e6, 1e6, allow_nan=False).map(repr)


def check_loaded(log: Log) -> None:
    """What every log that loads must satisfy."""
    assert len(log) >= 2
    assert list(log.data.columns) == ["t", "P", "x"]
    assert np.isfinite(log.data.to_numpy()).all()
    assert (np.diff(log.t) > 0).all()


def load_or_hmid_error(load) -> None:
    """Call ``load``; it must return a valid log or raise an HmidError (nothing else)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HmidWarning)
        warnings.simplefilter("ignore", RuntimeWarning)  # overflow in np.diff of huge times
        try:
            log = load()
        except HmidError as err:
            assert "\n" not in str(err)
            event(type(err).__name__)
            return
    event("loaded")
    check_loaded(log)


@st.composite
def messy_csv(draw) -> tuple[bytes, bool]:
    """(file content, whether it has a header line)."""
    labels = draw(
        st.one_of(
            st.permutations(LABELS[:3]),
            st.permutations(LABELS),
            st.lists(st.sampled_from(LABELS), max_size=5),  # subsets, repeats, any order
        )
    )
    n = draw(st.integers(0, 8))
    columns = []
    for label in labels:
        if label == "time" and draw(st.booleans()):
            # mostly regular time with the odd duplicate (0), long gap (50) or step back (-1)
            steps = st.sampled_from([1, 1, 1, 1, 2, 0, 50, -1])
            times = np.cumsum(draw(st.lists(steps, min_size=n, max_size=n)))
            column = [str(v) for v in times]
        else:
            cell = st.one_of(good_cells, bad_cells) if draw(st.booleans()) else good_cells
            column = draw(st.lists(cell, min_size=n, max_size=n))
        columns.append(column)
    sep = draw(st.sampled_from(SEPARATORS))
    header = draw(st.booleans())
    lines = [sep.join(labels)] if header else []
    for row in zip(*columns, strict=True) if columns else [()] * n:
        cut = draw(st.integers(0, len(row))) if draw(st.integers(0, 9)) == 0 else len(row)
        lines.append(sep.join(row[:cut]))  # sometimes a ragged (short) row
    end = draw(st.sampled_from(["\n", "\r\n"]))
    return (end.join(lines) + draw(st.sampled_from(["", end]))).encode(), header


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@FUZZ
@given(
    table=messy_csv(),
    mismatch=st.integers(0, 4),
    sep=st.sampled_from([None, None, None, *SEPARATORS]),
)
def test_messy_csv_ends_in_hmid_error_or_valid_log(folder, table, mismatch, sep):
    content, header = table
    path = folder / "messy.csv"
    path.write_bytes(content)
    # mostly the map that fits the file's header; sometimes the other one
    columns = NAMED if header == (mismatch > 0) else POSITIONAL
    if sep is not None:
        columns = columns.model_copy(update={"delimiter": "whitespace" if sep == " " else sep})
    load_or_hmid_error(lambda: read_log(path, columns))


@FUZZ
@given(
    content=st.one_of(
        st.binary(max_size=400),
        st.binary(max_size=400).map(lambda b: b.replace(b"\0", b"")),  # past the NUL check
        st.text(max_size=200).map(str.encode),
        st.binary(max_size=200).map(lambda b: b"PAR1" + b + b"PAR1"),  # Parquet magic
    ),
    suffix=st.sampled_from([".csv", ".parquet", ".txt"]),
)
def test_random_bytes_end_in_hmid_error(folder, content, suffix):
    path = folder / f"bytes{suffix}"
    path.write_bytes(content)
    load_or_hmid_error(lambda: read_log(path, NAMED))
    load_or_hmid_error(lambda: read_log(path, POSITIONAL))


object_cells = st.one_of(
    st.floats(),
    st.integers(-(2**70), 2**70),
    st.none(),
    st.text(max_size=5),
    st.booleans(),
    st.lists(st.integers(), max_size=2),
)


@st.composite
def messy_frame(draw) -> pd.DataFrame:
    labels = draw(st.lists(st.sampled_from([*LABELS, 0, 1, 2]), max_size=5))
    n = draw(st.integers(0, 8))
    data = {}
    for j in range(len(labels)):
        if draw(st.booleans()):
            cells = draw(st.lists(st.floats(), min_size=n, max_size=n))
            data[j] = np.asarray(cells, dtype="float64")
        else:
            data[j] = pd.Series(draw(st.lists(object_cells, min_size=n, max_size=n)), dtype=object)
    frame = pd.DataFrame(data, index=range(n))
    frame.columns = labels  # repeats allowed
    return frame


@FUZZ
@given(frame=messy_frame(), columns=st.sampled_from([NAMED, POSITIONAL]))
def test_messy_frame_ends_in_hmid_error_or_valid_log(frame, columns):
    load_or_hmid_error(lambda: log_from_frame(frame, columns, source="fuzz"))


@st.composite
def good_table(draw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 40))
    # steps between 1 and 2 ms: worst gap <= 2 x median, below the 3 x gap flag and max_gap_factor
    steps = draw(st.lists(st.integers(1, 2), min_size=n - 1, max_size=n - 1))
    t = np.concatenate([[draw(st.integers(-1000, 1000))], steps]).cumsum().astype(float)
    finite = st.floats(-1e5, 1e5, allow_nan=False)
    p = np.asarray(draw(st.lists(finite, min_size=n, max_size=n)))
    x = np.asarray(draw(st.lists(st.floats(1.0, 254.0), min_size=n, max_size=n)))  # inside rails
    return t, p, x


@FUZZ
@given(
    table=good_table(),
    sep=st.sampled_from(SEPARATORS),
    header=st.booleans(),
    end=st.sampled_from(["\n", "\r\n"]),
)
def test_well_formed_tables_load_exactly(folder, table, sep, header, end):
    t, p, x = table
    lines = [sep.join(["time", "p", "pos"])] if header else []
    lines += [sep.join(repr(float(v)) for v in row) for row in zip(t, p, x, strict=True)]
    path = folder / "good.csv"
    path.write_text(end.join(lines) + end, newline="")
    with warnings.catch_warnings():
        warnings.simplefilter("error", HmidWarning)  # nothing is at a rail
        log = read_log(path, NAMED if header else POSITIONAL)
        from_frame = log_from_frame(pd.DataFrame({"time": t, "p": p, "pos": x}), NAMED)
    scale_x = 0.5e-3 if header else 1e-3  # NAMED maps pos as ADC counts x 0.5 mm
    np.testing.assert_allclose(log.t, t * 1e-3, rtol=1e-12)
    np.testing.assert_allclose(log["P"], p * 1e3, rtol=1e-12)
    np.testing.assert_allclose(log["x"], x * scale_x, rtol=1e-12)
    np.testing.assert_allclose(from_frame["x"], x * 0.5e-3, rtol=1e-12)
    assert log.flags == ()
