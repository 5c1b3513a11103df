"""bim2rdt.safety"""
