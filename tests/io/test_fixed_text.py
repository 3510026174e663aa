"""The compiled fixed-point writer against a plain-Python twin of its rule (rint of value * 10**d)."""

import numpy as np
import pytest

from tankcd_cli.io.fixed_text import format_table, table_text


def _twin(numbers, decimals, codes, labels, kinds, index):
    rows = []
    for i in range(numbers.shape[0]):
        cells = []
        for kind, j in zip(kinds, index):
            if kind == 1:
                cells.append(labels[codes[i, j]])
                continue
            v = float(numbers[i, j])
            if not np.isfinite(v):
                cells.append("")
                continue
            d = int(decimals[j])
            r = int(np.rint(v * 10 ** d))
            sign = "-" if r < 0 else ""
            r = abs(r)
            cells.append(sign + str(r // 10 ** d) + ("." + str(r % 10 ** d).zfill(d) if d else ""))
        rows.append(",".join(cells) + "\n")
    return "".join(rows)


@pytest.mark.parametrize("seed", range(4))
def test_table_text_is_its_rule(seed):
    rng = np.random.default_rng(seed)
    n = 500
    numbers = rng.normal(0, 10 ** rng.uniform(-3, 7, 9), (n, 9))
    numbers[rng.random((n, 9)) < 0.05] = np.nan
    numbers[rng.random((n, 9)) < 0.02] = -np.inf
    numbers[rng.random((n, 9)) < 0.03] = -0.0
    numbers[rng.random((n, 9)) < 0.05] = rng.integers(-20, 20, 1) * 0.5  # ties: rint goes to even
    numbers[:, 0] = 5e5 + rng.uniform(0, 1000, n)  # UTM-size
    decimals = rng.integers(0, 9, 9)
    labels = ["flat", "general", "", "x"]
    codes = rng.integers(0, len(labels), (n, 2))
    kinds = np.array([0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0])
    index = np.array([0, 0, 1, 2, 3, 4, 1, 5, 6, 7, 8])
    assert table_text(numbers, decimals, codes, labels, kinds, index) == _twin(numbers, decimals, codes, labels, kinds, index)


def test_format_table_takes_any_layout_and_dtype():
    rng = np.random.default_rng(7)
    numbers = rng.normal(0, 100, (40, 6)).astype(np.float32)[:, ::2]  # float32, not contiguous
    decimals = np.array([3, 0, 5], np.int32)
    codes = np.zeros((40, 1), np.int32)
    kinds, index = np.zeros(3, np.int32), np.arange(3)
    out = np.zeros(4000, np.uint8)
    used = format_table(numbers, decimals, codes, np.zeros((1, 1), np.uint8), np.zeros(1, np.int64), kinds, index, out)
    assert isinstance(used, int)
    assert out[:used].tobytes().decode() == _twin(numbers.astype(np.float64), decimals, codes, [""], kinds, index)
    # a strided output buffer is written in place
    strided = np.zeros(8000, np.uint8)
    assert format_table(numbers, decimals, codes, np.zeros((1, 1), np.uint8), np.zeros(1, np.int64), kinds, index,
                        strided[::2]) == used
    assert np.array_equal(strided[::2][:used], out[:used])


def test_empty_tables_and_too_large_values():
    assert table_text(np.zeros((0, 2)), np.array([1, 2]), np.zeros((0, 1), np.int64), ["a"], np.array([0, 0]),
                      np.array([0, 1])) == ""
    assert table_text(np.array([[1e12]]), np.array([4]), np.zeros((1, 1), np.int64), ["a"], np.array([0]),
                      np.array([0])) is None
    with pytest.raises(ZeroDivisionError):  # 10 ** -1 is 0 in integer arithmetic
        format_table(np.ones((1, 1)), np.array([-1]), np.zeros((1, 1), np.int64), np.zeros((1, 1), np.uint8),
                     np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(10, np.uint8))


@pytest.mark.parametrize("big", [1e308, -1e305, 2.0 ** 60])
def test_values_whose_scaled_form_overflows_are_too_large_without_a_warning(big):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert table_text(np.array([[1.0, big]]), np.array([4, 4]), np.zeros((1, 1), np.int64), ["a"],
                          np.array([0, 0]), np.array([0, 1])) is None


@pytest.mark.parametrize("threads", [1, 2])
def test_row_blocks_in_parallel_give_the_one_pass_bytes(threads):
    """Tables of several row blocks are formatted block by block in parallel, each block at its
    rows' bound, then moved together: the bytes of the serial pass and of the rule, whatever the
    threads, with a last block shorter than the others; an error in one block is raised."""
    from tankcd_cli.threads import get_num_threads, set_num_threads

    rng = np.random.default_rng(11)
    n = 3 * 8192 + 17
    numbers = rng.normal(0, 10 ** rng.uniform(-3, 7, 5), (n, 5))
    numbers[rng.random((n, 5)) < 0.05] = np.nan
    numbers[:, 0] = 5e5 + rng.uniform(0, 1000, n)
    decimals = np.array([3, 0, 6, 2, 9])
    labels = ["flat", "general", "", "uneven"]
    codes = rng.integers(0, len(labels), (n, 1))
    kinds, index = np.array([0, 1, 0, 0, 0, 0]), np.array([0, 0, 1, 2, 3, 4])
    table = np.zeros((len(labels), 7), np.uint8)
    for k, s in enumerate(labels):
        table[k, :len(s)] = np.frombuffer(s.encode(), np.uint8)
    lengths = np.array([len(s) for s in labels], np.int64)
    bound = int(np.sum(19 + decimals)) + 8 + 1
    before = get_num_threads()
    set_num_threads(threads)
    try:
        blocks, block_ends = np.zeros(n * bound, np.uint8), np.zeros(n, np.int64)
        used = format_table(numbers, decimals, codes, table, lengths, kinds, index, blocks, bound, block_ends)
        one, one_ends = np.zeros(n * bound, np.uint8), np.zeros(n, np.int64)
        assert format_table(numbers, decimals, codes, table, lengths, kinds, index, one, 0, one_ends) == used
        assert blocks[:used].tobytes() == one[:used].tobytes()
        newlines = np.flatnonzero(one[:used] == 10) + 1  # each row's end: after its newline
        np.testing.assert_array_equal(block_ends, newlines)
        np.testing.assert_array_equal(one_ends, newlines)
        assert blocks[:used].tobytes().decode() == _twin(numbers, decimals, codes, labels, kinds, index)
        bad = decimals.copy()
        bad[4] = -1  # 10 ** -1 is no int64 scale: the kernel's error, from whichever block meets it
        with pytest.raises(ZeroDivisionError):
            format_table(numbers, bad, codes, table, lengths, kinds, index, np.zeros(n * bound, np.uint8), bound)
    finally:
        set_num_threads(before)
