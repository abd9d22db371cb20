import sys
from pathlib import Path

# the test oracle modules (e.g. stiffness_reference) are imported by name
sys.path.insert(0, str(Path(__file__).parent))
