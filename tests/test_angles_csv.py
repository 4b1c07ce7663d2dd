"""The angle CSV: exact text by hand, degrees, chunked writing, round trips, reader errors."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from plantlod.formats.angles_csv import AnglesCsvWriter, read_angles_csv
from plantlod.lsys.errors import InputError


def write(addresses, times, bend, rot, degrees=False, chunks=1):
    out = io.StringIO()
    writer = AnglesCsvWriter(out, addresses, degrees=degrees)
    for part in np.array_split(np.arange(len(times)), chunks):
        writer.write(np.asarray(times)[part], np.asarray(bend)[part], np.asarray(rot)[part])
    return out.getvalue()


def test_text_by_hand():
    text = write(["0", "0.10:1"], [0.0, 0.5],
                 [[0.0, -0.0], [1.5, 1e-12]],
                 [[0.1234567890123, -2.0], [3.0, 1.0 / 3.0]])
    assert text == ("t,b:0,r:0,b:0.10:1,r:0.10:1\n"
                    "0,0,0.123456789,0,-2\n"
                    "0.5,1.5,3,1e-12,0.3333333333\n")


def test_degrees_converts_angles_not_times():
    text = write(["7"], [0.25], [[math.pi / 2]], [[-math.pi]], degrees=True)
    assert text == "t,b:7,r:7\n0.25,90,-180\n"


def test_header_only_when_nothing_is_written_and_chunks_concatenate():
    out = io.StringIO()
    AnglesCsvWriter(out, ["0", "1"])
    assert out.getvalue() == "t,b:0,r:0,b:1,r:1\n"
    rng = np.random.default_rng(4)
    times, bend, rot = np.arange(9) * 0.1, rng.normal(size=(9, 2)), rng.normal(size=(9, 2))
    assert write(["0", "1"], times, bend, rot, chunks=4) == write(["0", "1"], times, bend, rot)


@settings(max_examples=40, deadline=None)
@given(b=st.integers(0, 5), m=st.integers(1, 6), data=st.data(), degrees=st.booleans())
def test_round_trip_to_ten_significant_digits(b, m, data, degrees):
    angles = hnp.arrays(np.float64, (m, b), elements=st.floats(-1e3, 1e3, allow_subnormal=False))
    bend, rot = data.draw(angles), data.draw(angles)
    times = np.cumsum(data.draw(hnp.arrays(np.float64, m, elements=st.floats(1e-3, 10.0))))
    addresses = [f"0.{i}" for i in range(b)]
    t2, a2, b2, r2 = read_angles_csv(io.StringIO(write(addresses, times, bend, rot, degrees)),
                                     "x.csv", degrees=degrees)
    assert a2 == addresses and b2.shape == (m, b) and r2.shape == (m, b)
    np.testing.assert_allclose(t2, times, rtol=6e-10)
    for got, want in ((b2, bend), (r2, rot)):
        np.testing.assert_allclose(got, want, rtol=6e-10, atol=1e-300)


@pytest.mark.parametrize("text,line,col,pattern", [
    ("", 1, 1, "the file is empty"),
    ("time,b:0,r:0\n", 1, 1, "start with 't'"),
    ("t,b:0\n", 1, 1, "b:ADDR and an r:ADDR"),
    ("t,x:0,r:0\n", 1, 3, "expected a column b:ADDR"),
    ("t,b:0,r:1\n", 1, 7, "expected the column r:0 after b:0"),
    ("t,b:0,r:0,b:0,r:0\n", 1, 11, "appears twice"),
    ("t,b:0,r:0\n", 2, 1, "at least one row"),
    ("t,b:0,r:0\n0,1\n", 2, 1, "expected 3 fields like the header, got 2"),
    ("t,b:0,r:0\n0,1,abc\n", 2, 5, "expected a finite number, got 'abc'"),
    ("t,b:0,r:0\n0,inf,1\n", 2, 3, "finite number"),
    ("t,b:0,r:0\n0,1,1\n0,2,2\n", 3, 1, "expected times to increase"),
    # float() reads these as 10 and 1: digits are ASCII, as written (session 23, fuzzing)
    ("t,b:0,r:0\n0,1_0,1\n", 2, 3, "got '1_0'"),
    ("t,b:0,r:0\n0,0,\u0661\n", 2, 5, "got '\u0661'"),
    ("t,b:0,r:0\n0,\uff11,0\n", 2, 3, "got '\uff11'"),
])
def test_reader_errors_are_located(text, line, col, pattern):
    with pytest.raises(InputError, match=pattern) as err:
        read_angles_csv(io.StringIO(text), "a.csv")
    assert (err.value.file, err.value.line, err.value.col) == ("a.csv", line, col)


def test_reader_accepts_crlf_and_blank_lines():
    times, addresses, bend, rot = read_angles_csv(io.StringIO("t,b:0,r:0\r\n\r\n0,1,2\r\n1,3,4\r\n\n"))
    assert addresses == ["0"] and times.tolist() == [0.0, 1.0]
    assert bend.tolist() == [[1.0], [3.0]] and rot.tolist() == [[2.0], [4.0]]


@pytest.mark.parametrize("block", [1, 7, 9, 1 << 20])
def test_rows_read_in_blocks_are_the_rows_of_the_file(monkeypatch, block):
    """The reader gathers rows in numpy blocks of about CSV_BLOCK_VALUES values (a list of
    Python floats took four times the text's bytes); any block size gives the file's
    numbers, against numpy's own parse of the same text, and an error past a block still
    names its line."""
    from plantlod.formats import angles_csv

    monkeypatch.setattr(angles_csv, "CSV_BLOCK_VALUES", block)
    rng = np.random.default_rng(7)
    rows = np.column_stack([np.arange(11) * 0.01, rng.normal(size=(11, 4))])
    text = "t,b:0,r:0,b:1,r:1\n" + "".join(",".join(f"{v:.10g}" for v in row) + "\n" for row in rows)
    times, addresses, bend, rot = read_angles_csv(io.StringIO(text), "a.csv")
    table = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1)
    assert addresses == ["0", "1"]
    np.testing.assert_array_equal(times, table[:, 0])
    np.testing.assert_array_equal(bend, table[:, 1::2])
    np.testing.assert_array_equal(rot, table[:, 2::2])
    bad = text.splitlines()
    bad[10] = bad[10].replace(",", ",x", 1)
    with pytest.raises(InputError) as info:
        read_angles_csv(io.StringIO("\n".join(bad) + "\n"), "a.csv")
    assert info.value.line == 11
