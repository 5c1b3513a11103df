"""The paper's registration benchmark: ICP vs SG-ICP (and Open3D peers) on seeded scenarios, scored against the
simulated truth."""
