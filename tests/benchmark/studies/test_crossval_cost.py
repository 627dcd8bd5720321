"""``benchmark.studies.crossval_cost``'s comparison of two runs' summaries: any changed digit,
or a missing table, is reported."""

import pandas as pd

from benchmark.studies.crossval_cost import compare_summaries


def test_identical_tables_compare_equal_and_a_changed_digit_does_not(tmp_path):
    tables = {"summary": pd.DataFrame({"method": ["adapted", "unadapted"],
                                       "mr": [0.123456789, 0.5]}),
              "sweep": pd.DataFrame({"estimate": [0.0, 0.1], "mr": [0.3, 0.2]})}
    for name, df in tables.items():
        df.to_csv(tmp_path / f"{name}.csv", index=False)
    assert compare_summaries(tmp_path, tables) == []
    changed = dict(tables, summary=tables["summary"].assign(mr=[0.123456788, 0.5]))
    assert compare_summaries(tmp_path, changed) == ["summary"]
    extra = dict(tables, paired=pd.DataFrame({"diff": [0.1]}))
    assert compare_summaries(tmp_path, extra) == ["paired"]
