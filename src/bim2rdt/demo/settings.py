"""The settings a demo runs with: the environment's (:func:`bim2rdt.config.get_settings`), with the demo's own
defaults where the environment sets nothing. Every part of a demo run reads them through :func:`demo_settings`
(its HAV day, its ``config.json``), so what the record says is what ran."""

from __future__ import annotations

from bim2rdt.config import Settings, get_settings

DEMO_RAW_RETENTION_S = 0.0
"""Seconds the demo's HAV day keeps raw batches once framed: none (``BIM2RDT_HAV__RAW_RETENTION_S`` overrides).
Its exposure, activities and events are all kept in ``state/hav.sqlite``; its raw samples (2 wearables x 1 h at
5 kHz: 227 MB, written twice through the WAL) have no reader: ``bim2rdt serve`` reveals raw windows from its own
live monitor (``out/demo/live``). A short retention would not help either: it counts from receipt on the wall
clock, and the day replays an hour's shift in seconds, so any retention longer than the replay keeps it all."""


def demo_settings(settings: Settings | None = None) -> Settings:
    """``settings`` (default: the process's) with the demo's defaults for what the environment left unset."""
    settings = get_settings() if settings is None else settings
    if "raw_retention_s" in settings.hav.model_fields_set:
        return settings
    hav = settings.hav.model_copy(update={"raw_retention_s": DEMO_RAW_RETENTION_S})
    return settings.model_copy(update={"hav": hav})
