"""Test configuration shared by the whole suite."""

import atexit
import os
import shutil
import tempfile

from hypothesis import settings

# CI (CI=true) runs hypothesis derandomized, so a submission's result is reproducible; local runs
# keep exploring new examples (and store failures in .hypothesis/ for replay).
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")

# The engine's filter-design cache (longprofile.statespace.filter_design) writes under $LONGPROFILE_CACHE_DIR, else
# under the user's ~/.cache: every test process, and the commands it runs, use a folder of their own (removed at
# exit), so the tests never write the user's home.
_DESIGN_CACHE = tempfile.mkdtemp(prefix="longprofile-test-cache-")
os.environ["LONGPROFILE_CACHE_DIR"] = _DESIGN_CACHE
atexit.register(shutil.rmtree, _DESIGN_CACHE, ignore_errors=True)
