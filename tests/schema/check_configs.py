#!/usr/bin/env python3
"""Validates config/schema/penumbra-config.schema.json itself, every shipped config
against it, and checks that known-bad configs are rejected (so the schema is not
vacuous). Usage: check_configs.py SOURCE_DIR"""
import json
import pathlib
import sys

import jsonschema

root = pathlib.Path(sys.argv[1])
schema = json.loads((root / "config/schema/penumbra-config.schema.json").read_text())
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)

failures = 0
shipped = (sorted((root / "config").glob("*.json")) + sorted((root / "config/bench").glob("*.json"))
           + sorted((root / "tests/data/configs/include").glob("*.json")))
for path in shipped:
    errors = list(validator.iter_errors(json.loads(path.read_text())))
    expect_invalid = path.name.startswith("bad_")
    if bool(errors) != expect_invalid:
        failures += 1
        print(f"FAIL {path.relative_to(root)}: expected {'invalid' if expect_invalid else 'valid'}")
        for e in errors:
            print(f"  {'/' + '/'.join(map(str, e.absolute_path))}: {e.message}")

bad = {
    "unknown key": {"lights": [{"type": "point", "position": [0, 1, 0], "intensty": 3}]},
    "spot without target or direction": {"lights": [{"type": "spot", "position": [0, 1, 0]}]},
    "cone on a point light": {"lights": [{"type": "point", "position": [0, 1, 0], "outer_cone_deg": 3}]},
    "negative size": {"lights": [{"type": "rect", "position": [0, 1, 0], "direction": [0, -1, 0], "size": [1, -2]}]},
    "bad culling": {"culling": "sometimes"},
    "bad track target": {"animation": {"tracks": [{"target": "/camera/roll", "keys": [{"t": 0, "value": 1}]}]}},
    "gltf and generator": {"scene": {"gltf": "a.gltf", "generator": "box-grid"}},
    "zero width": {"output": {"width": 0}},
    "sweep with path and paths": {"sweep": [{"path": "/scene", "paths": ["/camera"], "values": [1]}]},
    "sweep label not a string": {"sweep": [{"path": "/scene", "values": [1], "labels": [2]}]},
    "pcss radius out of range": {"lights": [{"type": "point", "position": [0, 1, 0],
                                             "shadow": {"technique": "pcss", "max_filter_radius": 1000}}]},
    "vsm unknown variant": {"lights": [{"type": "point", "position": [0, 1, 0],
                                        "shadow": {"technique": "vsm", "variant": "msm"}}]},
    "hard parameter on vsm": {"lights": [{"type": "point", "position": [0, 1, 0],
                                          "shadow": {"technique": "vsm", "pcf_kernel": 3}}]},
}
for name, doc in bad.items():
    if validator.is_valid(doc):
        failures += 1
        print(f"FAIL schema accepts a bad config: {name}")

print(f"{len(shipped) + len(bad) - failures} passed, {failures} failed")
sys.exit(1 if failures else 0)
