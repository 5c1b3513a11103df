"""Library packages import each other only through their ``__all__`` (STYLE.md practice 11): ``from
bim2rdt.perception import Frame``, never ``from bim2rdt.perception.frame import Frame`` nor a name the package
does not export. Checked on the source's import statements (module level and inside functions), as
``test_layers.py`` checks the layers; a planted private import fails it.

``KNOWN`` lists the private imports left when the rule was written (issue 31): safety and the server on the bus's
and safety's internals, the mission on localization's check shots and planar helpers, the verify bag on the
sources' writer. It may only shrink: an entry that is no longer needed fails the test too, so the list stays
true."""

from __future__ import annotations

import ast
import importlib
import shutil
from pathlib import Path

import bim2rdt

PACKAGE = Path(bim2rdt.__file__).parent
NOT_LIBRARY = {"cli", "demo", "bench", "sim", "evaluation"}
"""The edge and the simulator: they may reach into the library's modules (the layers still bind them)."""

KNOWN = frozenset({
    "mission.absence -> perception.visibility.DepthView",
    "mission.absence -> perception.visibility.PlaceLook",
    "mission.absence -> perception.visibility.look_at_place",
    "mission.config -> perception.slab.SLAB_CLEARANCE",
    "mission.explained -> perception.background.SLAB_CLASSES",
    "mission.explained -> perception.structure.permanent_elements",
    "mission.explained -> perception.surfaces.KnownSurface",
    "mission.fitting -> perception.fitting.FitRules",
    "mission.fitting -> perception.fitting.Plausible",
    "mission.fitting -> perception.fitting.fit_detection",
    "mission.ground -> perception.slab.off_the_slab",
    "mission.robot -> localization.checkshots.StationCheck",
    "mission.robot -> localization.checkshots.check_shots",
    "mission.robot -> localization.planar.between",
    "mission.robot -> localization.planar.from_planar",
    "mission.robot -> localization.planar.to_planar",
    "mission.run -> perception.visibility.DepthView",
    "mission.run -> perception.visibility.see_through_fraction",
    "mission.verdict -> twin.verdict.against_tolerance",
    "perception.perceive -> registration.validation.MIN_SCENE_POINTS",
    "planning.zones -> safety.activity.ACTIVITY_ENDED",
    "planning.zones -> safety.activity.ACTIVITY_STARTED",
    "safety.analysis -> bus.event.Event",
    "safety.analysis -> bus.payloads.AccelBatch",
    "safety.engine -> bus.event.Event",
    "safety.engine -> bus.payloads.AccelBatch",
    "safety.ifc_sink -> bus.event.Event",
    "safety.ingest -> bus.event.Event",
    "safety.ingest -> bus.payloads.AccelBatch",
    "safety.ingest -> bus.payloads.MAX_BATCH_S",
    "safety.ingest -> bus.payloads.PayloadError",
    "safety.ingest -> bus.payloads.decode_status",
    "safety.ingest -> bus.topics.device_of",
    "safety.last_delivery -> bus.payloads.PayloadError",
    "safety.last_delivery -> bus.summaries.decode_summary",
    "safety.last_delivery -> bus.topics.device_of",
    "safety.monitor -> bus.event.Event",
    "safety.monitor -> bus.local.LocalBus",
    "safety.monitor -> bus.mqtt.MqttBus",
    "safety.monitor -> bus.nats_bus.NatsBus",
    "safety.outbox -> bus.event.Event",
    "safety.persistence -> bus.event.Event",
    "safety.persistence -> bus.partitions.partition_of",
    "safety.persistence -> bus.payloads.AccelBatch",
    "safety.reads -> bus.event.Event",
    "safety.reads -> bus.payloads.AccelBatch",
    "safety.retention -> bus.event.Event",
    "safety.sinks -> bus.event.Event",
    "safety.sinks -> bus.topics.events_topic",
    "safety.store -> bus.event.Event",
    "safety.store -> bus.payloads.AccelBatch",
    "safety.store -> bus.payloads.MAX_BATCH_S",
    "safety.streams -> bus.payloads.AccelBatch",
    "safety.subscriber -> bus.event.Event",
    "safety.subscriber -> bus.payloads.AccelBatch",
    "safety.subscriber -> bus.payloads.PayloadError",
    "safety.subscriber -> bus.payloads.decode_accel",
    "safety.subscriber -> bus.summaries.DeviceSummary",
    "safety.subscriber -> bus.summaries.decode_summary",
    "safety.subscriber -> bus.topics.device_of",
    "safety.subscriber -> bus.topics.wearable_pattern",
    "safety.summary -> bus.summaries.DeviceSummary",
    "safety.weighing -> bus.payloads.AccelBatch",
    "server.hub -> bus.event.Event",
    "server.safety_view -> safety.exposure.EAV",
    "server.safety_view -> safety.exposure.ELV",
    "server.safety_view -> safety.exposure.T0_S",
    "server.twin_view -> twin.sink.recorded_outbox_ids",
    "twin.deviation -> registration.symmetry.closest_equivalent",
    "twin.ifc_export -> safety.ifc_sink.IfcSink",
    "twin.status -> perception.observation.ElementStatus",
    "verify.publish -> perception.observation.ElementStatus",
    "verify.publish -> planning.grid.KEEPOUT_KINDS",
    "verify.publish -> planning.grid.STRUCTURE_KINDS",
    "verify.publish -> sources.bag_writer.BagWriter",
    "verify.publish -> sources.tf.translation_quaternion",
})


def library_packages() -> set[str]:
    return {p.parent.name for p in PACKAGE.glob("*/__init__.py")} - NOT_LIBRARY


def exported() -> dict[str, set[str]]:
    """{package: its ``__all__``}."""
    return {name: set(getattr(importlib.import_module(f"bim2rdt.{name}"), "__all__", ()))
            for name in library_packages()}


def private_imports(package_dir: Path, exports: dict[str, set[str]]) -> set[str]:
    """Each import in a library package of another library package's module, or of a name it does not export,
    as ``"importer -> module.name"`` (package-relative, no line numbers: moving code keeps its entry)."""
    found = set()
    for path in sorted(package_dir.rglob("*.py")):
        parts = path.relative_to(package_dir).with_suffix("").parts
        if len(parts) < 2 or parts[0] not in exports:
            continue
        importer = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("bim2rdt."):
                module = node.module.split(".")[1:]
                if module[0] not in exports or module[0] == parts[0]:
                    continue
                for alias in node.names:
                    if len(module) > 1 or alias.name not in exports[module[0]]:
                        found.add(f"{importer} -> {'.'.join(module)}.{alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    module = alias.name.split(".")[1:]
                    if alias.name.startswith("bim2rdt.") and len(module) > 1 and module[0] in exports \
                            and module[0] != parts[0]:
                        found.add(f"{importer} -> {'.'.join(module)}")
    return found


def test_library_packages_import_each_other_only_through_their_all():
    new = private_imports(PACKAGE, exported()) - KNOWN
    assert not new, "private cross-package imports (make the name public in its package's __all__, with a " \
                    "docstring, and import it from the package):\n" + "\n".join(sorted(new))


def test_a_planted_private_import_is_refused(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "bim2rdt", ignore=shutil.ignore_patterns("__pycache__"))
    chain = tmp_path / "bim2rdt" / "verify" / "chain.py"
    chain.write_text(chain.read_text() + "\nfrom bim2rdt.localization.cloud import OccludedMap  # noqa: E402,F401\n"
                     "\n\ndef _f():\n    from bim2rdt.perception import background  # noqa: F401\n")
    found = private_imports(tmp_path / "bim2rdt", exported()) - KNOWN
    assert found == {"verify.chain -> localization.cloud.OccludedMap", "verify.chain -> perception.background"}


def test_known_private_imports_are_all_still_there():
    """The allowance only shrinks: an entry nothing needs any more must be struck off."""
    stale = KNOWN - private_imports(PACKAGE, exported())
    assert not stale, "no longer imported, strike off KNOWN:\n" + "\n".join(sorted(stale))
