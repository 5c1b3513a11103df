"""`bim2rdt bench localization`: a 100 m tour of the embedded site on drifting odometry; dead reckoning, BIM fixes
and the fused estimate scored against the truth, with Open3D's point-to-plane ICP on the same frames and starts."""
