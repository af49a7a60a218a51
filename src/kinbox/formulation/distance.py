"""placeholder"""
def supports(model):
    return "not yet"
