"""bim2rdt.registration"""
