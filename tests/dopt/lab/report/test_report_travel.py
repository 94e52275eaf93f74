"""base.travel_cell: the goal object's travel beside the paper, the authors' run of a row
against ours, in cm, and "-" for what a summary does not hold."""

from dopt.lab.report.base import travel_cell


def test_travel_in_cm_authors_first():
    assert travel_cell({"travel_median": 0.1143}, {"travel_median": 0.152}) == "11.4 / 15.2"


def test_missing_values_are_dashes():
    assert travel_cell(None, {"travel_median": 0.2}) == "- / 20.0"
    assert travel_cell({"travel_median": None}, {}) == "- / -"
