"""Every validation error is a one-line LogError naming file, column, channel, row and fix."""

import re
import warnings

import numpy as np
import pandas as pd
import pytest

from hmid.errors import HmidWarning, LogError, UnitError
from hmid.io import ChannelSpec, ColumnMap, log_from_frame, read_log

COLUMNS = ColumnMap(
    channels={
        "t": ChannelSpec(column="time", unit="ms"),
        "P": ChannelSpec(column="p", unit="bar"),
        "x": ChannelSpec(column="pos", unit="mm"),
    }
)
HEADERLESS = ColumnMap(
    channels={
        "t": ChannelSpec(column=0, unit="ms"),
        "P": ChannelSpec(column=1, unit="bar"),
        "x": ChannelSpec(column=4, unit="mm"),
    },
    header=False,
)


def write(tmp_path, text, name="a.csv"):
    path = tmp_path / name
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


def log_error(path, columns=COLUMNS, error=LogError, **kwargs) -> str:
    """The message of the error read_log raises, checked to be one line about ``path``."""
    with pytest.raises(error) as info:
        read_log(path, columns, **kwargs)
    message = str(info.value)
    assert "\n" not in message and "\r" not in message
    assert message.startswith(f"{path}: ")
    return message.removeprefix(f"{path}: ")


def table(*rows: str) -> str:
    return "time,p,pos\n" + "".join(f"{row}\n" for row in rows)


def test_missing_named_column_lists_the_file_columns(tmp_path):
    path = write(tmp_path, "time,pressure,pos\n0,1,2\n10,1,2\n")
    assert log_error(path) == (
        "column 'p' (channel P): no such column; the table has 3 column(s): 'time', 'pressure', "
        "'pos'; fix 'column' in the column map"
    )


def test_missing_position_in_headerless_file_gives_column_count(tmp_path):
    path = write(tmp_path, "0\t1\t2\n10\t1\t2\n")
    assert log_error(path, HEADERLESS) == (
        "column 4 (channel x): the table has only 3 column(s) (positions 0 to 2); "
        "fix the position or the delimiter"
    )


def test_duplicated_column_name_in_a_frame():
    frame = pd.DataFrame([[0, 1, 2, 3], [1, 1, 2, 3]], columns=["time", "p", "p", "pos"])
    with pytest.raises(
        LogError, match=r"column 'p' \(channel P\): the column name appears 2 times"
    ):
        log_from_frame(frame, COLUMNS)


def test_wrong_unit_dimension_is_unit_error_at_read(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,2"))
    columns = COLUMNS.model_copy(
        update={"channels": {**COLUMNS.channels, "P": ChannelSpec(column="p", unit="mm")}}
    )
    assert log_error(path, columns, UnitError) == (
        "column 'p' (channel P): unit 'mm' is a [length], channel P needs a [pressure] unit "
        "such as Pa, kPa, bar, psi"
    )


def test_unknown_unit_is_unit_error_at_read(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,2"))
    columns = COLUMNS.model_copy(
        update={"channels": {**COLUMNS.channels, "x": ChannelSpec(column="pos", unit="mmm")}}
    )
    message = log_error(path, columns, UnitError)
    assert message.startswith("column 'pos' (channel x): unknown unit 'mmm'; write a unit such as")


def test_non_numeric_value_names_row_line_and_text(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,2", "20,1.2.3,2", "30,oops,2"))
    assert log_error(path) == (
        "column 'p' (channel P): row 3 (line 4): non-numeric value '1.2.3' (2 such cell(s) in "
        "this column); fix the cell or the delimiter"
    )


def test_long_non_numeric_text_is_truncated(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1," + "z" * 500))
    message = log_error(path)
    assert message.startswith("column 'pos' (channel x): row 2 (line 3): non-numeric value 'zzz")
    assert len(message) < 200


def test_row_and_line_count_skipped_comment_and_blank_lines(tmp_path):
    text = "logger v2\nrun 4\n# ch: time p pos\ntime;p;pos\n0;1;2\n\n# pause\n10;1;2\n20;1;x\n"
    path = write(tmp_path, text)
    columns = COLUMNS.model_copy(update={"skip_rows": 2, "comment": "#"})
    assert log_error(path, columns).startswith(
        "column 'pos' (channel x): row 3 (line 9): non-numeric value 'x'"
    )


def test_non_numeric_in_a_frame_names_the_index_label():
    frame = pd.DataFrame({"time": [0, 1, 2], "p": [1.0, "n/a", 2.0], "pos": [0, 0, 0]})
    frame.index = [100, 101, 102]
    with pytest.raises(LogError) as info:
        log_from_frame(frame, COLUMNS, source="sim")
    assert str(info.value).startswith(
        "sim: column 'p' (channel P): row 2 (index 101): non-numeric value 'n/a'"
    )


@pytest.mark.parametrize("dtype", ["bool", "datetime64[ns]", "complex128"])
def test_non_real_dtypes_are_rejected(dtype):
    frame = pd.DataFrame({"time": [0, 1], "p": np.zeros(2).astype(dtype), "pos": [0.0, 0.0]})
    with pytest.raises(
        LogError, match=rf"sim: column 'p' \(channel P\): values are {re.escape(dtype)}"
    ):
        log_from_frame(frame, COLUMNS, source="sim")


def test_nan_reports_first_row_and_count(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,", "20,1,2", "30,1,NaN"))
    assert log_error(path) == (
        "column 'pos' (channel x): row 2 (line 3): value is missing/NaN; 2 non-finite value(s) "
        "in this column; fix or remove those rows (hmid does not fill or drop samples)"
    )


def test_short_row_is_a_missing_value(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1", "20,1,2"))
    assert log_error(path).startswith("column 'pos' (channel x): row 2 (line 3): value is missing")


@pytest.mark.parametrize(("cell", "shown"), [("inf", "inf"), ("-inf", "-inf")])
def test_infinite_value(tmp_path, cell, shown):
    path = write(tmp_path, table("0,1,2", "10,1,2", f"20,{cell},2"))
    assert log_error(path).startswith(
        f"column 'p' (channel P): row 3 (line 4): value is {shown}; 1 non-finite value(s)"
    )


def test_duplicated_time(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,2", "10,1,2", "20,1,2"))
    assert log_error(path) == (
        "column 'time' (channel t): row 3 (line 4): time repeats the previous row: t = 0.01 s "
        "then 0.01 s (1 such step(s)); time must strictly increase: remove duplicated or "
        "out-of-order rows"
    )


def test_time_going_back(tmp_path):
    path = write(tmp_path, table("0,1,2", "10,1,2", "20,1,2", "15,1,2", "30,1,2", "25,1,2"))
    assert log_error(path).startswith(
        "column 'time' (channel t): row 4 (line 5): time goes back from the previous row: "
        "t = 0.02 s then 0.015 s (2 such step(s))"
    )


@pytest.mark.parametrize(("n_rows", "needed"), [(0, 2), (1, 2), (5, 6)])
def test_too_few_samples_says_how_many_and_how_many_needed(tmp_path, n_rows, needed):
    path = write(tmp_path, table(*(f"{10 * i},1,2" for i in range(n_rows))))
    message = log_error(path, min_samples=needed if needed > 2 else None)
    assert message == (
        f"only {n_rows} sample(s), at least {needed} are needed (min_samples); "
        "use a longer log or shorter filter windows"
    )


def test_min_samples_from_caller_and_map_both_apply(tmp_path):
    path = write(tmp_path, table(*(f"{10 * i},1,2" for i in range(8))))
    strict = COLUMNS.model_copy(update={"min_samples": 9})
    assert "at least 9 are needed" in log_error(path, strict, min_samples=3)
    assert "at least 20 are needed" in log_error(path, strict, min_samples=20)
    assert len(read_log(path, COLUMNS, min_samples=8)) == 8


def test_irregular_sampling_reports_rate_gap_row_and_fix(tmp_path):
    times = [0, 10, 20, 30, 40, 50, 60, 310, 320, 330]  # one 250 ms gap in a 100 Hz log
    path = write(tmp_path, table(*(f"{t},1,2" for t in times)))
    assert log_error(path) == (
        "column 'time' (channel t): row 8 (line 9): gap of 0.25 s before this row is 25.0 x "
        "the median step 0.01 s (median rate 100 Hz, max_gap_factor 10); set "
        "max_gap_factor >= 25 in the column map to accept this log"
    )
    # the suggested fix works, and one less does not
    with pytest.warns(HmidWarning, match="1 gap"):  # accepted, but still reported
        assert len(read_log(path, COLUMNS.model_copy(update={"max_gap_factor": 25}))) == 10
    log_error(path, COLUMNS.model_copy(update={"max_gap_factor": 24}))


def adc_map(saturation: str) -> ColumnMap:
    return ColumnMap(
        channels={
            "t": ChannelSpec(column="time", unit="ms"),
            "P": ChannelSpec(column="p", unit="kPa", scale=0.25, adc_bits=10),
            "x": ChannelSpec(column="pos", unit="mm", range=(-5.0, 50.0)),
        },
        saturation=saturation,
    )


def test_adc_and_range_saturation_is_flagged_and_warned_but_kept(tmp_path):
    path = write(tmp_path, table("0,512,1", "10,1023,2", "20,1023,50", "30,0,60", "40,3,-5"))
    with pytest.warns(HmidWarning) as record:
        log = read_log(path, adc_map("flag"))
    assert log.flags == (
        f"{path}: column 'p' (channel P): row 2 (line 3): 3 sample(s) at the sensor rails "
        "(raw count 0 or 1023), first here; the signal is saturated there",
        f"{path}: column 'pos' (channel x): row 3 (line 4): 3 sample(s) at the sensor rails "
        "(range ends -5 or 50 mm), first here; the signal is saturated there",
    )
    ours = [str(w.message) for w in record if issubclass(w.category, HmidWarning)]
    assert ours == list(log.flags)
    # nothing clipped or dropped: 1023 counts * 0.25 kPa, and 60 mm beyond the 50 mm rail
    np.testing.assert_allclose(log["P"], [128e3, 255.75e3, 255.75e3, 0.0, 0.75e3], rtol=1e-12)
    np.testing.assert_allclose(log["x"], [0.001, 0.002, 0.05, 0.06, -0.005], rtol=1e-12)


def test_no_flag_inside_the_rails(tmp_path):
    path = write(tmp_path, table("0,1,-4.9", "10,1022,49.9"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", HmidWarning)
        assert read_log(path, adc_map("flag")).flags == ()


def test_saturation_error_mode_raises(tmp_path):
    path = write(tmp_path, table("0,512,1", "10,1023,2"))
    assert log_error(path, adc_map("error")) == (
        "column 'p' (channel P): row 2 (line 3): 1 sample(s) at the sensor rails (raw count 0 "
        "or 1023), first here; the signal is saturated there; re-record within the sensor "
        "range or set saturation: flag"
    )


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"", "the file is empty; expected a table with a time column"),
        (b"  \n\r\n\t\n", "the file is empty; expected a table with a time column"),
        (bytes(range(256)) * 4, "the file contains NUL bytes, so it is not a text table"),
        (b"time,p,pos\n0,1,\xff\xfe\n", "line 2 (byte 15) is not UTF-8 text: re-save the file"),
        (b"time,p,pos\n", "only 0 sample(s), at least 2 are needed"),
        (b"\xef\xbb\xbftime,p,pos\n0,1,2\n", "only 1 sample(s), at least 2 are needed"),
        (b"time,p,pos\n0,1,2,3\n10,1,2,3\n", "line 2 has 4 fields where the header has 3; check"),
        (b"time,p,pos\n0,1,2\n10,1,2,3\n", "line 3 has 4 fields where the header has 3; check"),
        (b'time,p,pos\n0,1,"2\n10,1,2\n', "cannot parse as a table: EOF inside string starting"),
        (b"# only a comment\n", "no table found (no data lines after skip_rows=0)"),
    ],
)
def test_files_that_are_not_tables(tmp_path, content, expected):
    path = write(tmp_path, content)
    assert log_error(path, COLUMNS.model_copy(update={"comment": "#"})).startswith(expected)


def test_single_headerless_line_is_too_few_samples(tmp_path):
    path = write(tmp_path, "0\t1\t2\t3\t4\n")
    assert log_error(path, HEADERLESS).startswith("only 1 sample(s), at least 2 are needed")


def test_text_without_the_columns_is_a_missing_column(tmp_path):
    path = write(tmp_path, "Dear colleague,\nplease find the data attached.\n")
    assert log_error(path).startswith("column 'time' (channel t): no such column; the table has")


def test_accepted_long_gap_is_flagged_not_hidden(tmp_path):
    t = [0.0, 0.01, 0.02, 0.27, 0.28, 0.29, 0.30, 0.31, 0.32, 0.33]
    path = tmp_path / "gappy.csv"
    path.write_text("time_ms,x_mm\n" + "".join(f"{1e3 * v:g},{i}\n" for i, v in enumerate(t)))
    columns = ColumnMap(
        channels={"t": {"column": "time_ms", "unit": "ms"}, "x": {"column": "x_mm", "unit": "mm"}},
        max_gap_factor=30,
    )
    with pytest.warns(HmidWarning, match="1 gap"):
        log = read_log(path, columns)
    assert len(log) == len(t)  # nothing dropped or filled
    (flag,) = log.flags
    assert "row 4" in flag and "worst 0.25 s (25.0 x)" in flag


def test_a_mapped_header_name_given_twice_is_an_error(tmp_path):
    path = tmp_path / "dup.csv"
    path.write_text("time,p,p,pos\n0,1,2,3\n10,1,2,3\n20,1,2,3\n")
    with pytest.raises(LogError, match=r"column 'p' \(channel P\) appears 2 times"):
        read_log(path, COLUMNS)


# -- plausibility of the time base (issue 13, item 4) -------------------------------------------
def time_table(path, times, column="t"):
    path.write_text(f"{column},p,pos\n" + "".join(f"{float(v)!r},1,2\n" for v in times))
    return path


def time_map(unit: str, **update) -> ColumnMap:
    channels = {"t": ChannelSpec(column="t", unit=unit), "x": ChannelSpec(column="pos", unit="mm")}
    return ColumnMap(channels=channels, **update)


@pytest.mark.parametrize("rows", [75_000, 15_000])
def test_seconds_mapped_as_ms_names_the_rate_and_the_unit_to_set(tmp_path, rows):
    # a 1 kHz log in seconds read as ms: 1 MHz, and with 15,000 rows 0.015 s, which the
    # denoise stage used to reject with "shorten the windows"
    path = time_table(tmp_path / "a.csv", np.arange(rows) * 1e-3)
    message = log_error(path, time_map("ms"))
    assert message == (
        f"column 't' (channel t): median sampling rate 1e+06 Hz ({rows} samples in "
        f"{(rows - 1) * 1e-6:.4g} s) is outside the plausible 1 to 100000 Hz; time looks like "
        "s mapped as 'ms': set channels.t.unit: s in the column map (or sample_rate_hz: "
        "[low, high] there if the rig really samples at 1e+06 Hz)"
    )
    assert len(read_log(path, time_map("s"))) == rows  # the suggested fix loads it


def test_ms_mapped_as_seconds_suggests_ms(tmp_path):
    path = time_table(tmp_path / "a.csv", np.arange(50) * 10.0)  # 100 Hz in ms
    message = log_error(path, time_map("s"))
    assert "median sampling rate 0.1 Hz" in message
    assert "time looks like ms mapped as 's': set channels.t.unit: ms" in message


def test_declared_rate_range_accepts_a_fast_rig_and_the_check_covers_frames(tmp_path):
    path = time_table(tmp_path / "a.csv", np.arange(100) * 1e-3)
    fast = time_map("ms", sample_rate_hz=(1e5, 2e6))
    assert read_log(path, fast).sample_rate == pytest.approx(1e6)
    frame = pd.DataFrame({"t": np.arange(100) * 1e-3, "pos": np.zeros(100)})
    with pytest.raises(LogError, match=r"^sim: column 't' \(channel t\): median sampling rate 1e"):
        log_from_frame(frame, time_map("ms"), source="sim")
    assert len(log_from_frame(frame, fast, source="sim")) == 100


def test_implausible_rate_without_a_plausible_unit_says_what_to_check(tmp_path):
    path = time_table(tmp_path / "a.csv", np.arange(50) * 1e-9)  # 1 GHz in seconds
    message = log_error(path, time_map("s"))
    assert "median sampling rate 1e+09 Hz" in message
    assert message.endswith(
        "check channels.t.unit and scale in the column map, or set sample_rate_hz: "
        "[low, high] there if the rig really samples at 1e+09 Hz"
    )
