"""The self-contained HTML report: images inline, the deviation table with the tolerance presets, ICP vs SG-ICP,
A(8) per worker against EAV/ELV, links to the files beside it; checked by parsing the page."""

from __future__ import annotations

import base64
import io
import re
from html.parser import HTMLParser

import cv2
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bim2rdt.evaluation.stats import MethodStats, ScenarioResult  # noqa: E402
from bim2rdt.demo.html_report import HtmlReport, WorkerExposure, write_html_report  # noqa: E402
from bim2rdt.perception.observation import Observation  # noqa: E402
from bim2rdt.twin import DigitalTwin, TwinConfig  # noqa: E402


class _Page(HTMLParser):
    """Collects the tables (as rows of cell text), images and links of a page."""

    def __init__(self):
        super().__init__()
        self.tables, self.images, self.links, self._cell = [], [], [], None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "img":
            self.images.append(attrs["src"])
        elif tag == "a":
            self.links.append(attrs["href"])

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def _png(colour: str) -> bytes:
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.fill([0, 1, 1], [0, 0, 1], color=colour)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return buffer.getvalue()


def _run(tmp_path):
    stats = {"ICP": MethodStats(0.0100, 0.006, 0.02, 0.80, 1.0, 20.0, 30),
             "SG-ICP": MethodStats(0.0040, 0.003, 0.01, 0.95, 0.2, 15.0, 30)}
    plot = tmp_path / "registration_S1.png"
    plot.write_bytes(_png("tab:blue"))

    class Run:
        trials, results, plots = 10, [ScenarioResult("S1", "cone, drum, crate", stats)], [plot]

    return Run()


def test_the_page_is_self_contained_with_every_section(tmp_path, site_model):
    twin = DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model)
    cone = next(el for el in site_model.elements if el.family == "Traffic_Cone_Orange_70cm")
    column = next(el for el in site_model.elements if el.ifc_class == "IfcColumn")
    moved = cone.placement.copy()
    moved[0, 3] += 0.25
    twin.record(Observation(cone.family, cone.global_id, moved, 0.004, 0.9, 200, station=1), 1.78e9)
    twin.record(Observation(column.family, column.global_id, column.placement, 0.002, 0.97, 300, station=2), 1.78e9)
    report = HtmlReport("Site day <test>", summary=["one line"], plan_png=_png("tab:green"), states=twin.state(),
                        tolerances=TwinConfig().tolerance_policy(), registration=_run(tmp_path),
                        exposure_png=_png("tab:red"),
                        workers=[WorkerExposure("w-aaaa", 3.1, 154.0), WorkerExposure("w-bbbb", 1.2, 23.0)],
                        links={"twin IFC": "site_twin.ifc", "BCF issues": "site_issues.bcf", "Nav2 map": "site.yaml"})
    path = write_html_report(report, tmp_path / "report.html")
    text = path.read_text()
    assert "<test>" not in text and "Site day &lt;test&gt;" in text
    page = _Page()
    page.feed(text)
    assert len(page.images) == 3 and all(src.startswith("data:image/png;base64,") for src in page.images)
    decoded = [cv2.imdecode(np.frombuffer(base64.b64decode(src.split(",", 1)[1]), np.uint8), cv2.IMREAD_COLOR)
               for src in page.images]
    assert all(image is not None and image.size > 0 for image in decoded)
    assert not re.search(r'src="(?!data:)', text)  # nothing to fetch
    assert page.links == ["site_twin.ifc", "site_issues.bcf", "site.yaml"]

    deviations, presets, registration, workers = page.tables
    by_id = {row[2]: row for row in deviations[1:]}
    assert by_id[cone.global_id][3] == "deviating" and by_id[cone.global_id][4] == "25.0"
    assert by_id[cone.global_id][7] == "temporary (5 cm / 5°)"
    assert by_id[column.global_id][3] == "as planned" and by_id[column.global_id][7] == "structural (1 cm / 0.5°)"
    assert len(deviations) == 3
    assert presets[1][:3] == ["temporary", "5", "5"] and "IfcBuildingElementProxy" in presets[1][3]
    assert "anything else" in presets[1][3] and "IfcColumn" in presets[2][3]
    assert registration[1][:5] == ["S1", "cone, drum, crate", "0.0100", "0.0040", "+60.0 %"]
    assert workers[1] == ["w-aaaa", "3.10", "154", "124 %", "above the EAV"]
    assert workers[2][-1] == "below the EAV"
    twin.close()


def test_an_empty_day_still_makes_a_page_that_says_so(tmp_path):
    path = write_html_report(HtmlReport("Empty"), tmp_path / "report.html")
    text = path.read_text()
    for phrase in ("No plan map", "No element observed", "Registration scenarios not run",
                   "No vibration exposure recorded"):
        assert phrase in text
