"""The column map config (hmid.io.columns) and its one-line errors."""

from pathlib import Path

import pytest
from pydantic import BaseModel, ValidationError

from hmid.errors import ConfigError
from hmid.io import ChannelSpec, ColumnMap, format_validation_error, load_column_map

REPO = Path(__file__).resolve().parents[2]
SPEC_KEYS = "column, unit, offset, scale, adc_bits, range"


def write_yaml(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def config_error(tmp_path: Path, text: str) -> str:
    path = write_yaml(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_column_map(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    return message.removeprefix(f"{path}: ")


def test_minimal_map_and_defaults():
    columns = ColumnMap(channels={"t": ChannelSpec(column="time", unit="s")})
    assert columns.delimiter is None and columns.sep is None
    assert columns.header is True
    assert columns.comment is None
    assert columns.skip_rows == 0
    assert columns.max_gap_factor == 10.0
    assert columns.min_samples == 2
    assert columns.saturation == "flag"
    spec = columns.channels["t"]
    assert (spec.offset, spec.scale, spec.adc_bits, spec.range) == (0.0, 1.0, None, None)


def test_models_are_frozen():
    columns = ColumnMap(channels={"t": ChannelSpec(column=0, unit="s")})
    with pytest.raises(ValidationError):
        columns.max_gap_factor = 3.0  # type: ignore[misc]
    with pytest.raises(ValidationError):
        columns.channels["t"].unit = "ms"  # type: ignore[misc]


def test_whitespace_delimiter_maps_to_pandas_regex():
    columns = ColumnMap(channels={"t": ChannelSpec(column=0, unit="s")}, delimiter="whitespace")
    assert columns.sep == r"\s+"


def test_load_yaml(tmp_path):
    path = write_yaml(
        tmp_path,
        """
delimiter: ";"
comment: "#"
skip_rows: 2
max_gap_factor: 25
min_samples: 10
saturation: error
channels:
  t: {column: time, unit: ms}
  P: {column: p_adc, unit: kPa, offset: -12.5, scale: 0.25, adc_bits: 12}
  x: {column: pos, unit: mm, range: [0, 50]}
""",
    )
    columns = load_column_map(path)
    assert list(columns.channels) == ["t", "P", "x"]
    assert columns.channels["P"] == ChannelSpec(
        column="p_adc", unit="kPa", offset=-12.5, scale=0.25, adc_bits=12
    )
    assert columns.channels["x"].range == (0.0, 50.0)
    assert (columns.delimiter, columns.comment, columns.skip_rows) == (";", "#", 2)
    assert (columns.max_gap_factor, columns.min_samples, columns.saturation) == (25, 10, "error")


def test_unknown_channel_key_names_path_and_allowed_keys(tmp_path):
    message = config_error(
        tmp_path, "channels:\n  t: {column: 0, unit: s}\n  P: {column: 1, unitt: kPa}\n"
    )
    # the misspelt key is reported first; the missing 'unit' it causes is counted
    assert message == (
        f"key 'channels.P.unitt': unknown key; allowed keys are {SPEC_KEYS} (and 1 more problem)"
    )


def test_unknown_top_level_key(tmp_path):
    message = config_error(tmp_path, "channels:\n  t: {column: 0, unit: s}\nmax_gap: 3\n")
    assert message == (
        "key 'max_gap': unknown key; allowed keys are channels, delimiter, header, comment, "
        "decimal, encoding, skip_rows, max_gap_factor, min_samples, saturation, sample_rate_hz"
    )


@pytest.mark.parametrize(
    ("yaml_text", "expected"),
    [
        ("channels: {P: {column: 0, unit: Pa}}", "key 'channels': channels must include the time"),
        ("channels: {t: {column: 0}}", "key 'channels.t.unit': required key is missing"),
        ("channels: {t: {column: 1.5, unit: s}}", "key 'channels.t.column': column must be a"),
        ("channels: {t: {column: true, unit: s}}", "key 'channels.t.column': column must be a"),
        ("channels: {t: {column: -1, unit: s}}", "key 'channels.t.column': column must be a"),
        ("channels: {t: {column: 0, unit: s, scale: 0}}", "key 'channels.t.scale': scale must"),
        ("channels: {t: {column: 0, unit: s, offset: .nan}}", "key 'channels.t.offset': must be"),
        ("channels: {t: {column: 0, unit: s, adc_bits: 0}}", "key 'channels.t.adc_bits': input"),
        ("channels: {t: {column: 0, unit: s, adc_bits: yes}}", "key 'channels.t.adc_bits': input"),
        ("channels: {t: {column: 0, unit: s, range: [5, 1]}}", "key 'channels.t.range': range"),
        ("channels: {t: {column: 0, unit: s, range: [0, x]}}", "key 'channels.t.range.1': input"),
        (
            "channels: {t: {column: 0, unit: s}, 2x: {column: 1, unit: s}}",
            "key 'channels': channel name '2x' must be",
        ),
        ("channels: {t: {column: 0, unit: s}}\nmax_gap_factor: 1", "key 'max_gap_factor': input"),
        ("channels: {t: {column: 0, unit: s}}\nmin_samples: 1", "key 'min_samples': input"),
        ("channels: {t: {column: 0, unit: s}}\nskip_rows: -2", "key 'skip_rows': input"),
        ("channels: {t: {column: 0, unit: s}}\nsaturation: clip", "key 'saturation': input"),
        ("channels: {t: {column: 0, unit: s}}\ndelimiter: ab", "key 'delimiter': delimiter must"),
        ("channels: {t: {column: 0, unit: s}}\ncomment: '##'", "key 'comment': comment must be"),
        (
            "channels: {t: {column: 0, unit: s}}\ncomment: ','\ndelimiter: ','",
            "comment and delimiter must differ",
        ),
        ("channels: [t, P]", "key 'channels': input should be a valid dictionary"),
        (
            "header: false\nchannels: {t: {column: time, unit: s}}",
            "channel 't' names column 'time' but header is false; give 0-based column positions",
        ),
        (
            "channels: {t: {column: 0, unit: s}, P: {column: 1, unit: mm}}",
            "key 'channels.P.unit': unit 'mm' is a [length], channel P needs a [pressure] unit",
        ),
        (
            "channels: {t: {column: 0, unit: sec0nds}}",
            "key 'channels.t.unit': unknown unit 'sec0nds'; write a unit such as s, ms",
        ),
    ],
)
def test_bad_values_are_one_line_config_errors_naming_the_key(tmp_path, yaml_text, expected):
    assert config_error(tmp_path, yaml_text).startswith(expected)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "a column map must be a YAML mapping with a 'channels' key, got NoneType"),
        ("- a\n- b\n", "a column map must be a YAML mapping with a 'channels' key, got list"),
        ("channels: {t: [\n", "not valid YAML at line 2"),
    ],
)
def test_unreadable_yaml(tmp_path, text, expected):
    assert config_error(tmp_path, text).startswith(expected)


def test_missing_file_is_config_error(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.yaml: cannot read column map"):
        load_column_map(tmp_path / "nope.yaml")


def test_format_validation_error_without_model_still_names_the_key():
    class Inner(BaseModel):
        a: int

    class Outer(BaseModel):
        inner: Inner | None = None
        pick: int | str = 0

    with pytest.raises(ValidationError) as info:
        Outer.model_validate({"inner": {"a": "x"}})
    assert format_validation_error(info.value, "c.toml") == (
        "c.toml: key 'inner.a': input should be a valid integer, unable to parse string as an "
        "integer (got 'x')"
    )
    # a failed union reports one key, without pydantic's member tags ('int', 'str')
    with pytest.raises(ValidationError) as info:
        Outer.model_validate({"pick": [1]})
    message = format_validation_error(info.value, "c.toml", Outer)
    assert message == "c.toml: key 'pick': input should be a valid integer (got [1])"


def test_shipped_pneumatic_map_loads():
    columns = load_column_map(REPO / "configs" / "logs" / "pneumatic-friction.yaml")
    assert columns.delimiter == "\t" and columns.header is False
    positions = {name: (spec.column, spec.unit) for name, spec in columns.channels.items()}
    assert positions == {
        "t": (0, "ms"),
        "x_raw": (1, "V"),
        "P_raw": (2, "V"),
        "F_raw": (3, "V"),
        "x": (4, "mm"),
        "P": (5, "bar"),
        "F": (6, "N"),
    }
    assert columns.max_gap_factor == 300


@pytest.mark.parametrize(
    ("yaml_text", "expected"),
    [
        ("decimal: ';;'", "key 'decimal': decimal must be one character"),
        ("decimal: ','\ndelimiter: ','", "decimal and delimiter must differ"),
        ("encoding: klingon", "key 'encoding': unknown encoding 'klingon'"),
        ("encoding: utf-16", "key 'encoding': encoding 'utf-16' is not ASCII-compatible"),
        ("sample_rate_hz: [5, 1]", "key 'sample_rate_hz': sample_rate_hz must be [low, high]"),
        ("sample_rate_hz: [0, 10]", "key 'sample_rate_hz': sample_rate_hz must be [low, high]"),
        ("sample_rate: [1, 10]", "key 'sample_rate': unknown key"),
    ],
)
def test_text_format_and_rate_keys_are_validated(tmp_path, yaml_text, expected):
    text = f"channels: {{t: {{column: 0, unit: s}}}}\n{yaml_text}"
    assert config_error(tmp_path, text).startswith(expected)


def test_text_format_and_rate_keys_load(tmp_path):
    text = (
        "channels: {t: {column: 0, unit: s}}\ndelimiter: ';'\ndecimal: ','\nencoding: latin-1\n"
        "sample_rate_hz: [10, 2000]\n"
    )
    columns = load_column_map(write_yaml(tmp_path, text))
    assert (columns.decimal, columns.encoding) == (",", "latin-1")
    assert columns.sample_rate_hz == (10.0, 2000.0)
    defaults = ColumnMap(channels={"t": ChannelSpec(column=0, unit="s")})
    assert (defaults.decimal, defaults.encoding) == (".", "utf-8")
    assert defaults.sample_rate_hz == (1.0, 100_000.0)


def test_a_folder_given_as_column_map_says_so(tmp_path):
    with pytest.raises(ConfigError, match=r"^\S+: is a folder, not a column map; give the path"):
        load_column_map(tmp_path)
