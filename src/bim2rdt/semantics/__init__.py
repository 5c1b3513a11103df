"""bim2rdt.semantics"""
