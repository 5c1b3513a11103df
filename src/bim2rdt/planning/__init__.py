"""bim2rdt.planning"""
