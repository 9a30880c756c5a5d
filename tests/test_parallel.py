"""map_ordered: the same results in input order on every executor; errors surface."""

from concurrent.futures import ThreadPoolExecutor

import pytest

from mocapkit.parallel import describe_executor, map_ordered


def square(x):
    return x * x


def fail_on_three(x):
    if x == 3:
        raise ValueError("three")
    return x


@pytest.mark.parametrize("executor", ["serial", "processes", None])
def test_results_in_input_order(executor):
    assert map_ordered(square, range(20), executor=executor, progress=False) == [x * x for x in range(20)]


def test_any_executor_with_submit():
    with ThreadPoolExecutor(3) as pool:
        assert map_ordered(square, [3, 1, 2], executor=pool, progress=False) == [9, 1, 4]


def test_first_error_is_raised():
    with pytest.raises(ValueError, match="three"):
        map_ordered(fail_on_three, range(6), executor="processes", progress=False)


def test_empty_and_bad_executor():
    assert map_ordered(square, [], progress=False) == []
    with pytest.raises(ValueError, match="executor: expected"):
        map_ordered(square, [1, 2], executor=42, progress=False)
    assert "local processes" in describe_executor(None)
