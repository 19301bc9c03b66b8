"""longprofile.vehicle."""
