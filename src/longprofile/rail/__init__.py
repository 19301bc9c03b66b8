"""longprofile.rail."""
