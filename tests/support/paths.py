"""The repository's folders, for tests that run scripts or read files by path."""
import os

SUPPORT = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.dirname(SUPPORT)
ROOT = os.path.dirname(TESTS)          # the repository (the snell package)
SCENES = os.path.join(ROOT, "scenes")
