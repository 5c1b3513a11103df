"""bim2rdt.bim"""
