"""The paper's registration scenarios run end to end: ICP vs SG-ICP (and Open3D and small_gicp peers) on seeded
scenarios and scene families, scored against the simulated truth, with their targets and plots. Shared by
``bim2rdt bench registration`` and the demo, which do not import each other."""
