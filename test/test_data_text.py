"""A logger's CSV as users bring it: any of the encodings and line endings spreadsheets and phones write,
and larger than a scene file, read line by line (textfile.text_lines under columns.read_csv_rows). A
byte-order mark is no part of the first value or name; binary data and devices are refused in one line."""

from __future__ import annotations

import codecs
import re
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.columns import read_columns
from pendulum_accel.physics.profiles import Table
from pendulum_accel.textfile import MAX_TEXT_BYTES, text_encoding, text_lines
from test.conftest import cli
from test.refusal import one_line_error

HEADER = ("Zeit (s)", "Beschleunigung (m/s²)")  # "²" is one byte in Windows-1252, two in UTF-8


def spreadsheet_text(separator: str = ";") -> str:
    """A decimal-comma export with a non-ASCII header and CRLF rows, as a German-locale Excel writes."""
    rows = [separator.join(HEADER)]
    rows += [f"{0.01 * k:.2f}{separator}{0.25 * k - 3.0:.2f}".replace(".", ",") for k in range(60)]
    return "\r\n".join(rows) + "\r\n"


ENCODED = {
    "utf-8": spreadsheet_text().encode("utf-8"),
    "utf-8 with its mark": codecs.BOM_UTF8 + spreadsheet_text().encode("utf-8"),
    "Windows-1252": spreadsheet_text().encode("cp1252"),
    "UTF-16, Excel's Unicode Text": spreadsheet_text("\t").encode("utf-16"),
    "old Mac CR rows": spreadsheet_text().replace("\r\n", "\r").encode("utf-8"),
}


@pytest.mark.parametrize("kind", list(ENCODED))
def test_every_encoding_and_line_ending_reads_the_same_columns(kind: str, tmp_path: Path) -> None:
    """The same rows saved five ways give the same times, values and line numbers, exactly: the bytes differ,
    the digits parsed do not, and the header named with its "²" is found in each."""
    (tmp_path / "plain.csv").write_bytes(ENCODED["utf-8"])
    (tmp_path / "log.csv").write_bytes(ENCODED[kind])
    want = read_columns(tmp_path / "plain.csv", *HEADER, what="accel")
    got = read_columns(tmp_path / "log.csv", *HEADER, what="accel")
    assert np.array_equal(got.times, want.times) and np.array_equal(got.values, want.values)
    assert list(got.lines) == list(want.lines) == list(range(2, 62))
    assert got.values[0] == -3.0 and got.times[-1] == 0.59  # each the float of its written decimal


def test_the_encoding_is_the_marks_else_utf8_else_windows_1252() -> None:
    """text_encoding: a byte-order mark decides; else UTF-8 if the head decodes (a character cut at the
    head's end allowed); else Windows-1252; a NUL byte is binary, not text."""
    assert text_encoding(codecs.BOM_UTF8 + b"t") == "utf-8-sig"
    assert text_encoding(codecs.BOM_UTF16_LE + "t".encode("utf-16-le")) == "utf-16"
    assert text_encoding("m/s²".encode()) == "utf-8"
    assert text_encoding("m/s²".encode()[:-1]) == "utf-8"  # the head ends inside "²"
    assert text_encoding("m/s²".encode("cp1252")) == "cp1252"
    with pytest.raises(ValueError, match="NUL byte at offset 1"):
        text_encoding("t".encode("utf-16-le"))  # UTF-16 without its mark
    with pytest.raises(ValueError, match=r"not UTF-8 text \(byte 0x81 at offset 0\), nor Windows-1252"):
        text_encoding(b"\x81")  # undefined in Windows-1252 too


def test_a_late_undecodable_byte_and_binary_data_are_one_line_each(tmp_path: Path) -> None:
    """A byte the file's encoding cannot decode, past the head the encoding was read from, is refused
    naming its own line (not the line a read-ahead chunk had reached); a NUL byte is binary data."""
    rows = "".join(f"{k},{k}\n" for k in range(200_000))  # 1.3 MiB of ASCII: past the 1 MiB head
    # The head says UTF-8 ("m/s²" in UTF-8), and a Windows-1252 "²" comes past it.
    head = "t,a (m/s²)\n".encode()
    (tmp_path / "late.csv").write_bytes(head + rows.encode() + "# 1 m/s²\n".encode("cp1252"))
    with pytest.raises(ParameterError, match=r"late\.csv: line 200002 is not utf-8 text \(byte 0xb2\)"):
        read_columns(tmp_path / "late.csv", None, None, what="accel")
    (tmp_path / "nul.csv").write_bytes(b"t,a\n0,1\x00\n")
    with pytest.raises(ParameterError, match=r"nul\.csv: not text: a NUL byte at offset 7"):
        profile_from_dict({"type": "csv", "path": str(tmp_path / "nul.csv")})


@pytest.mark.parametrize("late", ["Windows-1252", "UTF-8"])
def test_an_ascii_head_leaves_the_encoding_to_the_first_other_bytes(late: str, tmp_path: Path) -> None:
    """ASCII reads the same in every encoding, so a file whose first MiB is ASCII has its encoding decided
    by its first non-ASCII line, however far down: a Windows-1252 "°" there reads as "°" (in a comment
    and in a text column), as does a UTF-8 one. The columns are those of the same file in pure ASCII."""
    rows = [f"{k},{0.001 * k!r},ok" for k in range(150_000)]  # 1.6 MiB of ASCII: past the 1 MiB head
    rows[120_000] = "# slope 3°, Zürich"
    rows[140_000] = f"140000,{0.001 * 140_000!r},Straße"
    text = "t,a,note\n" + "\n".join(rows) + "\n"
    encoded = text.encode("cp1252" if late == "Windows-1252" else "utf-8")
    (tmp_path / "log.csv").write_bytes(encoded)
    (tmp_path / "ascii.csv").write_text(text.encode("ascii", "replace").decode(), encoding="ascii")
    got = read_columns(tmp_path / "log.csv", "t", "a", what="accel")
    want = read_columns(tmp_path / "ascii.csv", "t", "a", what="accel")
    assert np.array_equal(got.times, want.times) and np.array_equal(got.values, want.values)
    read = all_lines(tmp_path / "log.csv")
    assert read[120_001] == "# slope 3°, Zürich\n" and read[140_001].endswith(",Straße\n")
    # After the choice the other encoding's bytes are refused on their line, naming the line that chose.
    if late == "Windows-1252":
        (tmp_path / "bad.csv").write_bytes(encoded + b"1,2,\x81\n")
        refusal = r"line 150002 is not Windows-1252 text \(byte 0x81\), the encoding line 120002 chose"
    else:
        (tmp_path / "bad.csv").write_bytes(encoded + "1,2,°\n".encode("cp1252"))
        refusal = r"line 150002 is not utf-8 text \(byte 0xb0\)"
    with pytest.raises(ValueError, match=refusal):
        all_lines(tmp_path / "bad.csv")
    (tmp_path / "neither.csv").write_bytes(b"t,a\n" * 300_000 + b"# \x81\n")
    with pytest.raises(ValueError, match=r"line 300001 is neither UTF-8 nor Windows-1252 text \(byte 0x81\)"):
        all_lines(tmp_path / "neither.csv")


def all_lines(path: Path) -> list[str]:
    """Every line text_lines gives of ``path``."""
    with text_lines(path) as lines:
        return list(lines)


def test_a_data_file_past_its_bound_is_refused_before_it_is_read(tmp_path: Path) -> None:
    """The bound is checked on the file's size, in one line with both figures (parsed: the size is printed
    to the MiB, so within half of one of 1 MiB + 4 bytes)."""
    (tmp_path / "log.csv").write_bytes(b"t,a\n" + b"0,1\n" * (1024**2 // 4))
    with pytest.raises(ValueError) as refused, text_lines(tmp_path / "log.csv", limit=1024**2 // 2):
        pass
    words = re.fullmatch(r"(\S+) MiB, more than the (\S+) MiB a data file may hold", str(refused.value))
    assert words is not None
    assert float(words[1]) == pytest.approx(1.0, abs=0.5) and float(words[2]) == 0.5


@pytest.mark.slow
def test_a_log_larger_than_a_scene_file_may_be_is_read(tmp_path: Path) -> None:
    """An hour of a phone's 400 Hz accelerometer in phyphox's layout is about 85 MiB, past the 64 MiB that
    bounds a scene file (read whole); a data file is streamed and reads. The values are copied from the
    file exactly, and each time is the float of its written decimal."""
    n = 1_200_000  # about 60 bytes a row: 72 MB
    times = [f"{0.0025 * k:.9E}" for k in range(n)]
    accels = [f"{0.001 * (k % 997) - 0.5:.9E}" for k in range(n)]
    with (tmp_path / "phone.csv").open("w", encoding="utf-8") as out:
        out.write('"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)","Acceleration z (m/s^2)"\n')
        out.writelines(f"{t},{a},0.000000000E0,9.810000000E0\n" for t, a in zip(times, accels, strict=True))
    assert (tmp_path / "phone.csv").stat().st_size > MAX_TEXT_BYTES
    spec = {"type": "accel_csv", "path": str(tmp_path / "phone.csv"), "time_column": "Time (s)",
            "accel_column": "Acceleration x (m/s^2)"}  # fmt: skip
    profile = profile_from_dict(spec)
    assert isinstance(profile, Table)
    assert np.array_equal(profile.times, np.array(times, dtype=float))
    assert np.array_equal(profile.accels, np.array(accels, dtype=float))


def test_a_byte_order_mark_is_not_part_of_the_first_value_or_name(tmp_path: Path) -> None:
    """A UTF-8 BOM (Excel, Windows tools) before a headerless first row or a header's first name: every
    row is read, and the first column is found by its name."""
    samples = [(0.1 * k, float(k % 7)) for k in range(60)]
    body = "".join(f"{t!r},{a!r}\n" for t, a in samples)
    (tmp_path / "bare.csv").write_bytes(b"\xef\xbb\xbf" + body.encode())
    (tmp_path / "named.csv").write_bytes(b"\xef\xbb\xbf" + ("time,ax\n" + body).encode())
    bare = profile_from_dict({"type": "accel_csv", "path": "bare.csv"}, base_dir=tmp_path)
    named = profile_from_dict(
        {"type": "accel_csv", "path": "named.csv", "time_column": "time", "accel_column": "ax"},
        base_dir=tmp_path,
    )
    table = profile_from_dict({"type": "csv", "path": "bare.csv"}, base_dir=tmp_path)
    for profile in (bare, named, table):
        assert profile.to_dict()["accels"] == [a for _, a in samples]  # all 60, as recorded
    columns = {"time_column": "time", "speed_column": "ax", "signed": True}
    speeds = profile_from_dict(
        {"type": "speed_csv", "path": "named.csv", "units": "m/s", **columns}, tmp_path
    )
    kept = speeds.to_dict()["speeds"]
    assert isinstance(kept, list) and len(kept) == 60


def test_odd_files_are_one_line(tmp_path: Path) -> None:
    (tmp_path / "binary.csv").write_bytes(b"\x89\xff\xfe\x00 not text")
    profile = "acceleration:\n  type: csv\n  path: {}\n"
    text = cli("scenes", "lecture_constant").stdout
    start = text.index("acceleration:")
    end = text.index("sensor:")
    for source, words in (("binary.csv", ("not text", "NUL byte")), ("/dev/zero", ("character device",))):
        scene = tmp_path / "csv_scene.yaml"
        scene.write_text(text[:start] + profile.format(source) + text[end:])
        one_line_error(cli("simulate", str(scene)), *words)
    one_line_error(cli("simulate", "/dev/zero"), "character device")
