"""Benchmark harnesses behind ``bim2rdt bench ...``: each compares against a peer or a floor measured in the same
run and prints a table (or JSON). Bench code may use the library and the simulator; no library package imports it."""
