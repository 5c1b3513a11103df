"""`bim2rdt priors`: the upright prior and detector label of every BIM family, from an IFC file or a list."""

from __future__ import annotations

from pathlib import Path

import typer

from rich.console import Console

from bim2rdt.cli.common import console, print_json, print_table

_status = Console(stderr=True)  # spinners go to stderr so --json output stays clean
_NOT_OBJECTS = frozenset({"IfcSpace", "IfcVirtualElement"})  # rooms and virtual boundaries: nothing to detect


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("priors")(priors_command)


def priors_command(
    ifc_file: Path | None = typer.Argument(None, help="IFC file whose element families get priors."),
    families: str | None = typer.Option(None, "--families", help="Comma-separated family names instead of a file."),
    llm: bool = typer.Option(False, "--llm", help="Ask the OpenAI-compatible endpoint of BIM2RDT_LLM__* settings "
                             "(extra llm); families it cannot answer fall back to the knowledge base."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Print each BIM family's detector label, upright bias, yaw-only flag, rotational symmetry about up (1 none,
    2 a crate, inf a drum) and source.

    The bias (0..1) weighs SG-ICP's soft upright term; source is knowledge-base, default (unknown family),
    llm, llm-cache, or "... (llm fallback)" with the reason in the JSON rationale."""
    from bim2rdt.config import get_settings
    from bim2rdt.semantics import get_prior_provider

    hints = _family_hints(ifc_file, families)
    settings = get_settings()
    provider = get_prior_provider(settings.llm if llm else None, settings.cache_dir)
    with _status.status(f"asking for {len(hints)} families' priors", spinner="dots"):
        priors = provider.priors(hints, ifc_classes={f: c for f, c in hints.items() if c})
    if as_json:
        print_json([{"family": family, "ifc_class": hints[family] or None, **prior.to_dict()}
                    for family, prior in priors.items()])
        return
    rows = [(family, prior.label, prior.upright_bias, "yes" if prior.yaw_only else "no",
             prior.to_dict()["symmetry"], prior.source) for family, prior in priors.items()]
    print_table("Upright priors per BIM family", ["family", "label", "bias", "yaw-only", "symmetry", "source"], rows)
    unknown = sum(not prior.known for prior in priors.values())
    console.print(f"{len(priors)} families, {unknown} unknown (default bias)")


def _family_hints(ifc_file: Path | None, families: str | None) -> dict[str, str]:
    """family -> IFC entity ('' when only names were given)."""
    if (ifc_file is None) == (families is None):
        raise typer.BadParameter("give either an IFC file or --families a,b,c (not both)")
    if families is not None:
        names = [name.strip() for name in families.split(",") if name.strip()]
        if not names:
            raise typer.BadParameter("--families is empty")
        return dict.fromkeys(names, "")
    with _status.status(f"reading {ifc_file}", spinner="dots"):
        return _ifc_families(ifc_file)


def _ifc_families(path: Path) -> dict[str, str]:
    """family -> IFC entity of every physical element with a family (spaces and virtual elements skipped)."""
    from bim2rdt.bim import load_ifc

    found: dict[str, str] = {}
    for element in load_ifc(path, geometry=False).elements:
        if element.family and element.ifc_class not in _NOT_OBJECTS:
            found.setdefault(element.family, element.ifc_class)
    return found
