"""Reading CSV/Parquet files and in-memory tables into logs (hmid.io.read)."""

import hashlib

import numpy as np
import pandas as pd
import pytest

from hmid.errors import LogError
from hmid.io import ChannelSpec, ColumnMap, Log, log_from_frame, read_log

NAMED = ColumnMap(
    channels={
        "t": ChannelSpec(column="time_ms", unit="ms"),
        "P": ChannelSpec(column="p_kpa", unit="kPa"),
        "x": ChannelSpec(column="pos_mm", unit="mm"),
    }
)
ROWS = [(0, 101.3, 12.5), (10, 200.0, 13.0), (20, 350.5, -1.5), (30, 0.0, 0.0)]
EXPECTED = {
    "t": [0.0, 0.01, 0.02, 0.03],
    "P": [101300.0, 200000.0, 350500.0, 0.0],
    "x": [0.0125, 0.013, -0.0015, 0.0],
}


def write_table(path, rows, sep=",", header=("time_ms", "p_kpa", "pos_mm"), end="\n"):
    lines = [sep.join(header)] if header else []
    lines += [sep.join(str(v) for v in row) for row in rows]
    path.write_text(end.join(lines) + end)
    return path


def assert_expected(log: Log) -> None:
    assert list(log.data.columns) == ["t", "P", "x"]
    for name, values in EXPECTED.items():
        np.testing.assert_allclose(log[name], values, rtol=1e-12, atol=1e-15)


def test_csv_with_header_in_si(tmp_path):
    path = write_table(tmp_path / "a.csv", ROWS)
    log = read_log(path, NAMED)
    assert_expected(log)
    assert dict(log.units) == {"t": "s", "P": "Pa", "x": "m"}
    assert log.source == str(path)
    assert log.flags == ()
    assert log.meta["file"] == str(path)
    assert log.meta["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert log.meta["format"] == "csv" and log.meta["delimiter"] == ","
    assert log.sample_rate == pytest.approx(100.0, rel=1e-12)


@pytest.mark.parametrize(
    ("sep", "name"), [(",", ","), ("\t", "\t"), (";", ";"), ("|", "|"), ("   ", "whitespace")]
)
@pytest.mark.parametrize("end", ["\n", "\r\n"])
def test_delimiter_is_sniffed(tmp_path, sep, name, end):
    path = write_table(tmp_path / "a.txt", ROWS, sep=sep, end=end)
    log = read_log(path, NAMED)
    assert_expected(log)
    assert log.meta["delimiter"] == name


def test_explicit_delimiter_and_whitespace(tmp_path):
    path = write_table(tmp_path / "a.dat", ROWS, sep=" \t ")
    assert_expected(read_log(path, NAMED.model_copy(update={"delimiter": "whitespace"})))
    path = write_table(tmp_path / "b.csv", ROWS, sep=";")
    assert_expected(read_log(path, NAMED.model_copy(update={"delimiter": ";"})))


def test_headerless_by_position_with_comments_and_skipped_lines(tmp_path):
    path = tmp_path / "a.csv"
    body = "\n".join("\t".join(str(v) for v in (*row, 9.9)) for row in ROWS)
    path.write_text(f"rig B, run 7\nsecond preamble line\n# comment\n\n{body}\n")
    columns = ColumnMap(
        channels={
            "t": ChannelSpec(column=0, unit="ms"),
            "P": ChannelSpec(column=1, unit="kPa"),
            "x": ChannelSpec(column=2, unit="mm"),
        },
        header=False,
        skip_rows=2,
        comment="#",
    )
    assert_expected(read_log(path, columns))


def test_only_mapped_columns_are_kept_and_a_column_may_feed_two_channels(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text("time_ms,junk,p_kpa,pos_mm,note\n0,x,1,2,a\n1,y,3,4,b\n")
    columns = ColumnMap(
        channels={
            "t": ChannelSpec(column="time_ms", unit="ms"),
            "P": ChannelSpec(column="p_kpa", unit="kPa"),
            "P_in_bar": ChannelSpec(column="p_kpa", unit="bar"),
        }
    )
    log = read_log(path, columns)
    assert list(log.data.columns) == ["t", "P", "P_in_bar"]
    np.testing.assert_allclose(log["P"], [1e3, 3e3], rtol=1e-12)
    np.testing.assert_allclose(log["P_in_bar"], [1e5, 3e5], rtol=1e-12)


def test_adc_counts_with_offset_and_scale_to_si(tmp_path):
    # 12-bit pressure ADC: kPa = -100 + 0.1 * counts; laser: mm = 2.5 + 0.01 * counts
    path = tmp_path / "adc.csv"
    path.write_text("t,p_adc,x_adc\n0,1000,10\n1,2048,250\n2,3000,4000\n")
    columns = ColumnMap(
        channels={
            "t": ChannelSpec(column="t", unit="s"),
            "P": ChannelSpec(column="p_adc", unit="kPa", offset=-100, scale=0.1, adc_bits=12),
            "x": ChannelSpec(column="x_adc", unit="mm", offset=2.5, scale=0.01, adc_bits=12),
            "P_adc": ChannelSpec(column="p_adc", unit="count"),
        }
    )
    log = read_log(path, columns)
    np.testing.assert_allclose(log["P"], [0.0, 104800.0, 200000.0], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(log["x"], [0.0026, 0.005, 0.0425], rtol=1e-12)
    np.testing.assert_array_equal(log["P_adc"], [1000.0, 2048.0, 3000.0])
    assert log.units["P_adc"] == "count"
    assert log.flags == ()


def test_parquet_by_name_and_position(tmp_path):
    frame = pd.DataFrame({"time_ms": [r[0] for r in ROWS], "p_kpa": [r[1] for r in ROWS]})
    frame["pos_mm"] = [r[2] for r in ROWS]
    for suffix in (".parquet", ".pq"):
        path = tmp_path / f"a{suffix}"
        frame.to_parquet(path)
        log = read_log(path, NAMED)
        assert_expected(log)
        assert log.meta["format"] == "parquet"
        assert log.meta["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    by_position = ColumnMap(
        channels={"t": ChannelSpec(column=0, unit="ms"), "x": ChannelSpec(column=2, unit="mm")}
    )
    np.testing.assert_allclose(read_log(path, by_position)["x"], EXPECTED["x"], rtol=1e-12)


def test_broken_parquet_is_log_error(tmp_path):
    path = tmp_path / "a.parquet"
    path.write_text("time_ms,p_kpa\n0,1\n")
    with pytest.raises(LogError, match=r"a\.parquet: cannot read as Parquet: "):
        read_log(path, NAMED)


def test_log_from_frame_matches_read_log(tmp_path):
    frame = pd.DataFrame(ROWS, columns=["time_ms", "p_kpa", "pos_mm"])
    log = log_from_frame(frame, NAMED, source="sim:seed=3")
    assert_expected(log)
    assert log.source == "sim:seed=3"
    from_file = read_log(write_table(tmp_path / "a.csv", ROWS), NAMED)
    pd.testing.assert_frame_equal(log.data, from_file.data)


def test_log_from_frame_rejects_non_frames():
    with pytest.raises(LogError, match=r"^<memory>: expected a pandas DataFrame, got dict$"):
        log_from_frame({"t": [0, 1]}, NAMED)  # type: ignore[arg-type]


def test_integer_and_nullable_columns_become_float64():
    frame = pd.DataFrame(
        {
            "time_ms": pd.array([0, 1, 2], dtype="Int64"),
            "p_kpa": np.array([1, 2, 3], dtype=np.int16),
            "pos_mm": pd.array([1.0, 2.0, 3.0], dtype="Float64"),
        }
    )
    log = log_from_frame(frame, NAMED)
    assert (log.data.dtypes == np.float64).all()
    np.testing.assert_allclose(log["P"], [1e3, 2e3, 3e3], rtol=1e-12)


def test_missing_file_is_log_error(tmp_path):
    with pytest.raises(LogError, match=r"nope\.csv: cannot read the file"):
        read_log(tmp_path / "nope.csv", NAMED)


def test_long_log_loads_fast(tmp_path):
    # 60 s at 1 kHz, 5 columns: the C parser should need a few tens of ms
    n = 60_000
    rng = np.random.default_rng(7)
    frame = pd.DataFrame(
        {
            "time_ms": np.arange(n, dtype=float),
            "p_kpa": 300 + rng.normal(0, 5, n),
            "pos_mm": rng.normal(10, 1, n),
            "f_n": rng.normal(50, 2, n),
            "v": rng.normal(0, 1, n),
        }
    )
    path = tmp_path / "long.csv"
    frame.to_csv(path, index=False, float_format="%.6f")
    columns = NAMED.model_copy(
        update={
            "channels": {
                **NAMED.channels,
                "F": ChannelSpec(column="f_n", unit="N"),
                "v": ChannelSpec(column="v", unit="mm/s"),
            }
        }
    )
    log = read_log(path, columns)
    assert len(log) == n and log.duration == pytest.approx(59.999, abs=1e-9)


def test_a_bad_cell_in_a_later_parse_chunk_is_named_by_row_and_line(tmp_path, recwarn):
    # the parser reads in chunks: the column is float in the first ones, mixed in the last
    n = 300_000
    lines = ["time_ms,p_kpa,pos_mm", *(f"{i},1.5,2.5" for i in range(n))]
    lines[n - 10 + 1] = f"{n - 10},1.5,oops"
    path = tmp_path / "long.csv"
    path.write_text("\n".join(lines) + "\n")
    message = read_error(path)
    assert message.startswith(
        f"column 'pos_mm' (channel x): row {n - 9} (line {n - 8}): non-numeric value 'oops'"
    )
    assert not [w for w in recwarn if "mixed types" in str(w.message)]
    lines[n - 10 + 1] = f"{n - 10},1.5,2.5"
    path.write_text("\n".join(lines) + "\n")
    assert read_log(path, NAMED)["x"][-10] == 2.5e-3


# -- text formats and their one-line hints (issue 13, item 8) -----------------------------------
def read_error(path, columns=NAMED) -> str:
    """The one-line LogError message of ``read_log``, without the ``<path>: `` prefix."""
    with pytest.raises(LogError) as info:
        read_log(path, columns)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    return message.removeprefix(f"{path}: ")


@pytest.mark.parametrize(
    ("sep", "name", "yaml"), [(";", "semicolon", '";"'), ("\t", "tab", '"\\t"')]
)
def test_one_column_from_a_wrong_delimiter_names_the_delimiter_in_the_header(
    tmp_path, sep, name, yaml
):
    path = write_table(tmp_path / "a.csv", ROWS, sep=sep)
    assert read_error(path, NAMED.model_copy(update={"delimiter": ","})) == (
        f"only one column when lines are split at comma, but the header line contains {name}s: "
        f"is the delimiter {name}? set delimiter: {yaml} in the column map"
    )


def test_decimal_comma_is_offered_and_then_read(tmp_path):
    path = tmp_path / "a.csv"
    rows = [("0", "101,3", "12,5"), ("10", "200", "13"), ("20", "350,5", "-1,5"), ("30", "0", "0")]
    path.write_text("time_ms;p_kpa;pos_mm\n" + "".join(";".join(r) + "\n" for r in rows))
    assert read_error(path) == (
        "column 'p_kpa' (channel P): row 1 (line 2): value '101,3' has a decimal comma "
        '(2 such cell(s) in this column); set decimal: "," in the column map'
    )
    assert_expected(read_log(path, NAMED.model_copy(update={"decimal": ","})))


def test_comment_lines_are_named_with_the_key_that_skips_them(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text(
        "# logger v2\n# 2026-11-02\n" + write_table(tmp_path / "b.csv", ROWS).read_text()
    )
    assert read_error(path) == (
        "line 1 starts with '#' but the column map sets no comment character: "
        'set comment: "#" in the column map to skip such lines'
    )
    assert_expected(read_log(path, NAMED.model_copy(update={"comment": "#"})))


def test_excel_sep_line_is_honoured_or_named(tmp_path):
    path = tmp_path / "a.csv"
    body = write_table(tmp_path / "b.csv", ROWS, sep=";").read_text()
    path.write_text("sep=;\n" + body.replace("350.5", "nan"))
    # honoured: the rows are counted after it (the NaN is in file line 5)
    assert read_error(path).startswith("column 'p_kpa' (channel P): row 3 (line 5): value is")
    path.write_text("sep=;\n" + body)
    log = read_log(path, NAMED)
    assert_expected(log)
    assert log.meta["delimiter"] == ";"
    assert read_error(path, NAMED.model_copy(update={"delimiter": ","})) == (
        'line 1 says sep=; (Excel\'s delimiter line) but the column map says delimiter: ","; '
        "remove one of them"
    )


def test_latin1_header_says_resave_or_set_encoding(tmp_path):
    path = tmp_path / "a.csv"
    lines = ["time_ms,p_kpa,pos_mm,T_°C", *(",".join(map(str, row)) + ",20" for row in ROWS)]
    path.write_bytes("\n".join(lines).encode("latin-1"))
    assert read_error(path) == (
        "line 1 (byte 23) is not UTF-8 text: re-save the file as UTF-8 or set encoding: "
        "latin-1 in the column map (cp1252 for Windows exports)"
    )
    columns = ColumnMap(
        channels=dict(NAMED.channels) | {"T": ChannelSpec(column="T_°C", unit="K")},
        encoding="latin-1",
    )
    log = read_log(path, columns)
    for name, values in EXPECTED.items():
        np.testing.assert_allclose(log[name], values, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(log["T"], 20.0)


def test_a_folder_is_named_with_what_it_holds(tmp_path):
    write_table(tmp_path / "b.csv", ROWS)
    write_table(tmp_path / "a.csv", ROWS)
    assert read_error(tmp_path) == (
        "is a folder, not a log file; give the path of one CSV or Parquet file "
        "(it holds a.csv, b.csv)"
    )


@pytest.mark.parametrize(
    ("columns", "preamble", "line", "where"),
    [
        (NAMED, "", 7, "the header has 3"),
        (
            NAMED.model_copy(update={"skip_rows": 1, "comment": "#"}),
            "junk\n# note\n",
            9,
            "the header has 3",
        ),
    ],
)
def test_a_ragged_line_is_named_by_its_file_line(tmp_path, columns, preamble, line, where):
    path = tmp_path / "a.csv"
    rows = "".join(f"{10 * i},1,2\n" for i in range(5))
    path.write_text(f"{preamble}time_ms,p_kpa,pos_mm\n{rows}50,1,2,3\n60,1,2\n")
    assert read_error(path, columns) == (
        f"line {line} has 4 fields where {where}; check the delimiter/quoting of that line"
    )


def test_a_ragged_headerless_line_is_named_by_its_file_line(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text("".join(f"{10 * i},1,2\n" for i in range(5)) + "50,1,2,3\n60,1,2\n")
    positional = ColumnMap(channels={"t": ChannelSpec(column=0, unit="ms")}, header=False)
    assert read_error(path, positional) == (
        "line 6 has 4 fields where the first row has 3; check the delimiter/quoting of that line"
    )


@pytest.mark.parametrize("encoding", ["utf-8", "cp1252", "utf-16"])
def test_a_logs_lines_are_read_one_at_a_time_as_a_split_of_its_whole_text(encoding):
    """A bad row's line is found without the text held whole where the line ends are single
    bytes, and the same lines either way (CRLF, CR and LF ends, a trailing end, accents)."""
    from hmid.io._csv import _NEWLINES, _lines

    text = "t,x\r\n1,é\r2,3\n\n# note\r\n4,5\n"
    assert list(_lines(text.encode(encoding), encoding)) == _NEWLINES.split(text)
