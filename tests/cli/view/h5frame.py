"""h5frame.py FILE.h5 GROUP FRAME: prints frame FRAME of GROUP/positions as a
JSON list of nv x 3 numbers (row-major), read with h5py, for the browser tests."""
import json
import sys

import h5py

with h5py.File(sys.argv[1], "r") as f:
    print(json.dumps(f[sys.argv[2]]["positions"][int(sys.argv[3])].astype(float).ravel().tolist()))
