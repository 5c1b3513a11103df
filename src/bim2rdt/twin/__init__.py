"""bim2rdt.twin"""
