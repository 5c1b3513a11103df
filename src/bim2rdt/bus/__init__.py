"""bim2rdt.bus"""
