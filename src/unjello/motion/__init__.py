"""Motion estimation: the paper's stages (V.A-V.C) and the methods that wire them."""
