"""bim2rdt.perception"""
