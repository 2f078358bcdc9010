"""The MICO's joints without end stops (1, 4, 5 and 6), as indices: stated here, not read from the package."""

WIDE = (0, 3, 4, 5)
