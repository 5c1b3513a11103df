"""`demo --publish` (and --record, --targets) runs on the embedded site: with --ifc it is refused in one line
before the day starts."""

from __future__ import annotations

from typer.testing import CliRunner

from bim2rdt.cli import app

runner = CliRunner()


def test_publish_with_another_building_is_refused_before_anything_runs(tmp_path):
    ifc = tmp_path / "other.ifc"
    ifc.write_text("ISO-10303-21;\nEND-ISO-10303-21;\n")
    result = runner.invoke(app, ["demo", "--out", str(tmp_path / "out"), "--ifc", str(ifc), "--publish",
                                 str(tmp_path / "results.mcap")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "--record, --publish and --targets run on the embedded site" in " ".join(result.output.split())
    assert not (tmp_path / "results").exists() and not (tmp_path / "out" / "site.ifc").exists()
