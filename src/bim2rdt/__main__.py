"""``python -m bim2rdt`` runs the CLI."""

from bim2rdt.cli import main

main()
