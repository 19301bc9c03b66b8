"""longprofile.identify."""
