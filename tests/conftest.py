"""Test configuration shared by the whole suite."""

import os

from hypothesis import settings

# CI (CI=true) runs hypothesis derandomized, so a submission's result is reproducible; local runs
# keep exploring new examples (and store failures in .hypothesis/ for replay).
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
