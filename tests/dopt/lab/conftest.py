"""The ``site`` fixture of the report tests (``report_site``)."""
from tests.dopt.lab.report.report_site import site  # noqa: F401
