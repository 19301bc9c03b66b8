"""The options of ``SettlementSettings`` added on 2026-12-06 (sessions 28-31): their default, the value that
``until_2026_12_06()`` restores, another accepted value, and a refused one (``InputError``, one line)."""

import pytest

from longprofile.errors import InputError
from longprofile.rail import SettlementSettings


@pytest.mark.parametrize("name, default, until, other, bad", [
    ("settlement_end_anchor", "all-days", "fixed", "fixed", "fit"),
    ("end_ambiguity", "off", "off", "mixture", "on"),
    ("witness_rule", "off", "off", "steps", "on"),
    ("reversal_null", "site", "model", "model", "empirical"),
])
def test_option_default_old_value_and_refusal(name, default, until, other, bad):
    assert getattr(SettlementSettings(), name) == default
    assert getattr(SettlementSettings.until_2026_12_06(), name) == until
    assert getattr(SettlementSettings(**{name: other}), name) == other
    with pytest.raises(InputError, match=name):
        SettlementSettings(**{name: bad})
