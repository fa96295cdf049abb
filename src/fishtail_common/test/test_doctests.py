import doctest

import pytest

import fishtail_common.command_line
import fishtail_common.interface
import fishtail_common.parameters


@pytest.mark.parametrize(
    "module",
    [fishtail_common.command_line, fishtail_common.interface, fishtail_common.parameters],
)
def test_doctests(module):
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
