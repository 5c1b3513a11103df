"""``bim2rdt bench perception``: the geometric detector against the ideal one (the renderer's masks) on frames
from the mission's stations in seeded realities of the embedded site, plus YOLOE's time per frame when the
``yoloe`` extra is installed, and what time-of-flight flying pixels and the edge filter do to S1."""
