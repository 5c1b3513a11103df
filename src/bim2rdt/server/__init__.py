"""bim2rdt.server"""
