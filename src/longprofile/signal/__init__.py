"""longprofile.signal."""
