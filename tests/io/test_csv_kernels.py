"""The compiled CSV chunk parser: edge cases of its fast path, bit for bit float()'s, and the inputs it takes."""

import numpy as np
import pytest

from tankcd_cli.io.csv_kernels import POW10, parse_table


def _float_table(text):
    return [float(c) for c in text.replace("\r", "").replace("\n", ",").split(",") if c.strip()]


@pytest.mark.parametrize("cell", [
    "0", "-0", "-0.0", "+0e5", "0e999", "0e400", "0.000000000000000000000000000", "1e22", "1e-22", "-9.99999999999999e22",
    "123456789012345", "0.123456789012345", "123456789012345e-22", "1" + "0" * 14 + "e7", "0" * 300 + "1.5",
    "500123.4567", "-4500987.123456", "5e-324e", ".5", "5.", "1E+05", "2e-0", "\t7 "])
def test_fast_path_cells_are_float_bits(cell):
    values, ok = parse_table(np.frombuffer(f"{cell},1\n".encode(), np.uint8), 1, 2, POW10)
    if ok:
        expect = np.array(_float_table(f"{cell},1"))
        assert values.ravel().view(np.uint64).tolist() == expect.view(np.uint64).tolist()
    else:
        assert cell in ("5e-324e", "0e999")  # a stray letter; an exponent past 400 even on a zero


@pytest.mark.parametrize("cell", ["1e23", "1e-23", "1234567890123456", "9" * 40, "1e401", "nan", "inf", "1e", "+", ""])
def test_off_the_fast_path_is_not_ok(cell):
    assert parse_table(np.frombuffer(f"{cell},1\n".encode(), np.uint8), 1, 2, POW10)[1] is False


def test_inputs_it_takes():
    text = b"1.5,2\n-3,4e2\n"
    base, ok = parse_table(np.frombuffer(text, np.uint8), 2, 2, POW10)
    assert ok is True and base.shape == (2, 2) and base.dtype == np.float64
    padded = np.zeros(2 * len(text), np.uint8)
    padded[::2] = np.frombuffer(text, np.uint8)
    for buf in (padded[::2], np.frombuffer(text, np.int8), list(text)):  # strided, another dtype, a list
        values, ok = parse_table(buf, 2, 2, list(POW10))
        assert ok is True and np.array_equal(values, base)
    values, ok = parse_table(np.zeros(0, np.uint8), 0, 3, POW10)
    assert ok is True and values.shape == (0, 3)
    assert parse_table(np.zeros(0, np.uint8), 1, 3, POW10)[1] is False
