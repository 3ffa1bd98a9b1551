"""Validates every message of MCAP logs against its channel's JSON Schema, as stored in the
log, with the `jsonschema` package (a validator that knows nothing of this project).

    python validate.py LOG...

Prints one line per log: `LOG: N messages valid` or the first invalid messages (at most 5
per channel) with the validator's words; exits 1 if any message is invalid.
"""

import json
import sys

import jsonschema
from mcap.reader import make_reader

bad_logs = 0
for path in sys.argv[1:]:
    validators = {}
    checked = 0
    invalid = {}
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema is None or schema.encoding != "jsonschema":
                invalid.setdefault(channel.topic, []).append("no JSON Schema")
                continue
            validator = validators.get(schema.id)
            if validator is None:
                text = json.loads(schema.data)
                cls = jsonschema.validators.validator_for(text)
                cls.check_schema(text)
                validator = cls(text)
                validators[schema.id] = validator
            value = json.loads(message.data)
            checked += 1
            errors = list(validator.iter_errors(value))
            if errors:
                seen = invalid.setdefault(channel.topic, [])
                if len(seen) < 5:
                    where = "/".join(str(p) for p in errors[0].absolute_path)
                    seen.append(f"{json.dumps(value)[:200]}: at '{where}': {errors[0].message}")
    if invalid:
        bad_logs += 1
        for topic, problems in invalid.items():
            for p in problems:
                print(f"{path}: channel {topic}: {p}")
    else:
        print(f"{path}: {checked} messages valid")
sys.exit(1 if bad_logs else 0)
