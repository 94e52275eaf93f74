"""The ``site`` fixture of the report tests: a results folder and README to render into."""
import pytest
import report


@pytest.fixture
def site(tmp_path):
    """A results folder, a README with the markers and the paths report.py writes."""
    readme = tmp_path / "README.md"
    readme.write_text(f"# project\n\nintro\n\n{report.BEGIN}\nstale\n{report.END}\n\nmore\n")
    results = tmp_path / "docs" / "results"
    results.mkdir(parents=True)
    return {"results": results, "md": tmp_path / "docs" / "RESULTS.md", "readme": readme}
