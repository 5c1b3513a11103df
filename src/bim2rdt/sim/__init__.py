"""bim2rdt.sim"""
