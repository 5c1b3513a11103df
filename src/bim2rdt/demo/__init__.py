"""The demo job on the embedded default site (``make demo``): a simulated site day and its report.

Demo code may use the library and the simulator; no library package imports it."""
