"""longprofile.report."""
