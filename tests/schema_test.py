#!/usr/bin/python3
"""Validates file formats against their JSON Schemas in docs/schemas/.

Every shipped JSON file (data/**, the reports in docs/) and every JSON file the
`tensegrity` program writes in a few typical runs must match the schema of its
"format" (a JSON Lines file: every line; `check --json` prints its document).
A broken copy of a scene, and of every report the program wrote, must not
match (the validator is live).

    /usr/bin/python3 tests/schema_test.py --source . --binary build/tensegrity
    /usr/bin/python3 tests/schema_test.py --source . --validate FILE...   (no program runs)

Exit status 0 when everything matches, 1 otherwise (each mismatch is printed).
"""
import argparse
import copy
import json
import pathlib
import subprocess
import sys
import tempfile

import jsonschema

SCHEMA_OF_FORMAT = {
    "tensegrity-scene": "scene",
    "tensegrity-solution": "solution",
    "tensegrity-character": "character",
    "tensegrity-block": "block",
    "tensegrity-material": "material",
    "tensegrity-design": "design",
    "tensegrity-stress-report": "stress-report",
    "tensegrity-batch-report": "batch-report",
    "tensegrity-poses": "poses",
    "tensegrity-actuation": "actuation",
    "tensegrity-compare": "compare",
    "tensegrity-link-suggestions": "link-suggestions",
    "tensegrity-simulation-frame": "simulation-frame",
    "tensegrity-naive-comparison": "naive-comparison",
    "tensegrity-check": "check",
}

# The duck's two poses of docs/CHARACTERS.md (head down 1 cm, head up 1 cm);
# actuation_outputs adds a third with a node target, so both kinds are exercised.
DUCK_POSES = {"format": "tensegrity-poses", "version": 1, "poses": [
    {"name": "down", "targets": [{"block": "head", "by": [0.0, -0.01, 0.0]}]},
    {"name": "left", "targets": [{"block": "head", "by": [0.0, 0.0, 0.01]}]},
]}

# Poses files the program rejects (exit 2), each of which the schema must reject too.
BAD_POSES = {
    "node without position": {"format": "tensegrity-poses", "version": 1,
                              "poses": [{"targets": [{"node": 3, "by": [0.0, 0.0, 0.01]}]}]},
    "two coordinates": {"format": "tensegrity-poses", "version": 1,
                        "poses": [{"targets": [{"block": "head", "by": [0.0, 0.01]}]}]},
    "no poses": {"format": "tensegrity-poses", "version": 1, "poses": []},
}


class Schemas:
    def __init__(self, folder):
        self.by_name = {}
        store = {}
        for path in sorted(folder.glob("*.schema.json")):
            schema = json.loads(path.read_text())
            jsonschema.Draft202012Validator.check_schema(schema)
            name = path.name[: -len(".schema.json")]
            if schema.get("$id") != path.name:
                raise SystemExit(f"{path}: $id must be {path.name!r}")
            self.by_name[name] = schema
            store[path.name] = schema
        missing = set(SCHEMA_OF_FORMAT.values()) - set(self.by_name)
        if missing:
            raise SystemExit(f"{folder}: no schema for {sorted(missing)}")
        self.validators = {}
        for name, schema in self.by_name.items():
            # Cross-file references ("scene.schema.json#/$defs/node") resolve from the folder, never the network.
            resolver = jsonschema.RefResolver(base_uri=schema["$id"], referrer=schema, store=store)
            self.validators[name] = jsonschema.Draft202012Validator(schema, resolver=resolver)

    def errors(self, document):
        """Messages of every mismatch; a document of no known format is one."""
        if not isinstance(document, dict) or document.get("format") not in SCHEMA_OF_FORMAT:
            return ["no known \"format\" (expected one of " + ", ".join(sorted(SCHEMA_OF_FORMAT)) + ")"]
        validator = self.validators[SCHEMA_OF_FORMAT[document["format"]]]
        return [
            "/".join(str(p) for p in error.absolute_path) + ": " + error.message
            for error in sorted(validator.iter_errors(document), key=lambda e: list(map(str, e.absolute_path)))
        ]


def shipped_files(source):
    files = sorted(p for p in (source / "data").rglob("*.json"))
    files += sorted((source / "docs").glob("*-report.json"))
    files += sorted((source / "docs" / "outputs").rglob("*.json"))
    # docs/figures also holds benchmark-library outputs, which are not the project's formats.
    files += sorted(p for p in (source / "docs" / "figures").glob("*.json")
                    if str(json.loads(p.read_text()).get("format", "")).startswith("tensegrity-"))
    return files


def json_files(work):
    return set(work.rglob("*.json")) | set(work.rglob("*.jsonl"))


def run_program(binary, args, work, stdout_to=None):
    """Runs the program; returns the JSON (and JSON Lines) files it wrote into
    `work`, and `stdout_to` holding what it printed when that is given."""
    before = json_files(work)
    done = subprocess.run([str(binary)] + [str(a) for a in args], capture_output=True, text=True, timeout=600)
    if done.returncode not in (0, 1):
        raise SystemExit(f"tensegrity {' '.join(map(str, args))}: exit {done.returncode}\n{done.stderr}")
    if stdout_to:
        stdout_to.write_text(done.stdout)
    return sorted(json_files(work) - before)


def program_outputs(source, binary, work):
    data = source / "data"
    prism = data / "reference" / "prism-3.scene.json"
    prism_gravity = data / "reference" / "prism-3-gravity.scene.json"
    runs = [
        ["solve", prism, "--out", work / "prism-3.solution.json", "--out-scene", work / "prism-3.solved.scene.json"],
        ["solve", prism_gravity, "--solver", "ipopt", "--out", work / "prism-3-gravity.solution.json"],
        ["forces", prism, "--out", work / "prism-3.forces.solution.json"],
        ["build", data / "characters" / "duck.character.json", "--out", work / "duck.scene.json"],
        ["build", "--write-blocks", work / "blocks"],
        ["generate", "reference", "--out-dir", work / "reference"],
        ["generate", "tower", "--layers", "2", "--struts-per-layer", "3", "--cables", "20", "--gravity",
         "--out", work / "tower.scene.json"],
        ["fit-material", data / "materials" / "elastic-cord-1mm.points.csv", "--out", work / "cord.json"],
        ["design", prism_gravity, "--material", "elastic-cord-1mm", "--material-dir", data / "materials",
         "--out", work / "prism-3.design.json"],
        ["relax", work / "prism-3.design.json", "--out", work / "prism-3.relaxed.solution.json"],
        ["batch", prism, prism_gravity, "--out-dir", work / "batch"],
        ["batch", prism, prism_gravity, "--solver", "alternating-gn,ipopt", "--jobs", "2", "--measure-speedup",
         "--out-dir", work / "batch-mixed", "--json", work / "batch-report.json"],
        ["stress-test", "--scenes", "prism-3", "--solvers", "alternating", "--families", "noise", "--trials", "1",
         "--no-times", "--quiet", "--data", data, "--out", work / "stress-report.json"],
        ["stress-test", "--scenes", "prism-3", "--solvers", "alternating-gn,ipopt", "--families", "noise",
         "--trials", "1", "--quiet", "--data", data, "--measure-speedup", "--jobs", "2",
         "--json", work / "stress-report-timed.json"],
        ["import", source / "tests" / "data" / "ntrt" / "3Prism.yaml", "--fix-lowest", "3",
         "--out", work / "3prism.scene.json"],
        ["compare", prism, "--solvers", "alternating-gn,ipopt", "--out", work / "compare"],
        ["suggest-link", data / "characters" / "duck.character.json", "--a", "body", "--b", "neck",
         "--axis", "0", "1", "0", "--range", "20", "--faces", "2", "--cables", "1", "--json", work / "links.json"],
        ["design", prism_gravity, "--material", "elastic-cord-1mm", "--material-dir", data / "materials",
         "--naive-fractions", "0.8:0.9:2", "--quiet", "--out", work / "prism-3.naive.design.json"],
        ["simulate", work / "prism-3.design.json", "--steps", "3", "--no-vtk", "--quiet",
         "--out", work / "prism-3.frames.jsonl"],
    ]
    written = []
    for args in runs:
        files = run_program(binary, args, work)
        if not files:
            raise SystemExit(f"tensegrity {' '.join(map(str, args))}: wrote no JSON file")
        written += files
    check = work / "prism-3.check.json"
    run_program(binary, ["check", prism, work / "prism-3.solution.json", "--json"], work, stdout_to=check)
    written.append(check)
    return written + actuation_outputs(binary, work)


def actuation_outputs(binary, work):
    """The duck of docs/CHARACTERS.md: solve, design, then `actuation --json`
    (the poses file is written here, the report by the program)."""
    duck = work / "duck.scene.json"  # built by program_outputs
    poses = work / "duck.poses.json"
    scene = json.loads(duck.read_text())
    node = next(i for i, n in enumerate(scene["nodes"]) if not n.get("fixed", False))
    target = [x + 0.005 for x in scene["nodes"][node]["x"]]
    document = copy.deepcopy(DUCK_POSES)
    document["poses"].append({"targets": [{"node": node, "position": target}]})
    poses.write_text(json.dumps(document, indent=1) + "\n")
    written = [poses]
    for args in (
        ["solve", duck, "--out", work / "duck.solution.json", "--quiet"],
        ["design", duck, "--out", work / "duck.design.json", "--quiet"],
        ["actuation", duck, "--solution", work / "duck.solution.json", "--poses", poses, "--max-actuators", "2",
         "--design", work / "duck.design.json", "--json", work / "duck.actuation.json"],
    ):
        files = run_program(binary, args, work)
        if not files:
            raise SystemExit(f"tensegrity {' '.join(map(str, args))}: wrote no JSON file")
        written += files
    report = json.loads((work / "duck.actuation.json").read_text())
    if [len(level["poses"]) for level in report["levels"]] != [3, 3] or report["levels"][0]["poses"][2]["name"] != "pose-2":
        raise SystemExit(f"{work / 'duck.actuation.json'}: expected 2 levels of 3 poses, the last named pose-2")
    return written


def check_bad_poses(schemas, binary, work):
    """Each bad poses file fails the schema and, with the program, exits 2."""
    failures = 0
    for what, document in BAD_POSES.items():
        if not schemas.errors(document):
            print(f"the poses schema accepted a bad poses file ({what})")
            failures += 1
        if binary:
            path = work / "bad.poses.json"
            path.write_text(json.dumps(document))
            done = subprocess.run([str(binary), "actuation", str(work / "duck.scene.json"), "--solution",
                                   str(work / "duck.solution.json"), "--poses", str(path), "--max-actuators", "1",
                                   "--design", str(work / "duck.design.json")],
                                  capture_output=True, text=True, timeout=600)
            if done.returncode != 2:
                print(f"tensegrity actuation accepted a bad poses file ({what}): exit {done.returncode}")
                failures += 1
    if schemas.errors(DUCK_POSES):
        print("the poses schema rejects the duck's poses: " + "; ".join(schemas.errors(DUCK_POSES)))
        failures += 1
    return failures


def documents_in(path):
    """The JSON documents of a file: one, or one per line of a JSON Lines file."""
    text = pathlib.Path(path).read_text()
    if str(path).endswith(".jsonl"):
        return [json.loads(line) for line in text.splitlines() if line.strip()]
    return [json.loads(text)]


def check_files(schemas, files):
    failures = 0
    for path in files:
        try:
            documents = documents_in(path)
        except (OSError, ValueError) as e:
            print(f"{path}: cannot read: {e}")
            failures += 1
            continue
        if not documents:
            print(f"{path}: no document")
            failures += 1
        for number, document in enumerate(documents):
            where = f"{path}:{number + 1}" if len(documents) > 1 else str(path)
            for message in schemas.errors(document):
                print(f"{where}: {message}")
                failures += 1
    return failures


def check_live(schemas, source):
    """A document that breaks its schema must be reported (else the test proves nothing)."""
    scene = json.loads((source / "data" / "reference" / "prism-3.scene.json").read_text())
    broken = []
    for mutate in (
        lambda s: s["nodes"][0].__setitem__("fixed", "yes"),
        lambda s: s["elements"][0].__setitem__("kind", "rod"),
        lambda s: s["nodes"][1].__setitem__("x", [0.0, 1.0]),
        lambda s: s.pop("elements"),
        lambda s: s.__setitem__("version", 2),
    ):
        copy_of_scene = copy.deepcopy(scene)
        mutate(copy_of_scene)
        broken.append(copy_of_scene)
    missed = [i for i, doc in enumerate(broken) if not schemas.errors(doc)]
    if schemas.errors(scene) or missed:
        print(f"the scene schema does not tell good from bad (accepted broken cases {missed})")
        return 1
    return 0


def check_live_actuation(schemas, path, document):
    failures = 0
    for mutate in (
        lambda d: d["levels"][0]["poses"][0].pop("reached_rms"),
        lambda d: d["levels"][0].__setitem__("actuators", 0),
        lambda d: d["levels"][0]["poses"][0].__setitem__("rest_length_change", "shorter"),
    ):
        broken = copy.deepcopy(document)
        mutate(broken)
        if not schemas.errors(broken):
            print(f"{path}: the tensegrity-actuation schema accepted a broken copy")
            failures += 1
    return failures


def measured_candidate(document):
    return next(c for c in document["candidates"] if c["measured"])


# Per format: ways to break a document the program wrote that its schema must
# reject (a wrong enum value, a missing required field, a number out of range,
# a wrong type).
BROKEN_COPIES = {
    "tensegrity-compare": (
        lambda d: d["rows"][0].__setitem__("status", "finished"),
        lambda d: d["rows"][0].pop("verified"),
        lambda d: d["rows"][0].__setitem__("iterations", -1),
        lambda d: d["rows"][0].__setitem__("seconds", "fast"),
    ),
    "tensegrity-link-suggestions": (
        lambda d: d["candidates"][0].__setitem__("type", "hinge"),
        lambda d: d["candidates"][0].pop("link"),
        lambda d: measured_candidate(d).pop("principal_stiffness"),
        lambda d: measured_candidate(d).__setitem__("principal_axes", [[1.0, 0.0, 0.0]]),
        lambda d: d.pop("units"),
    ),
    "tensegrity-simulation-frame": (
        lambda d: d["positions"][0].pop(),
        lambda d: d.pop("forces"),
        lambda d: d.__setitem__("step", -1),
        lambda d: d.pop("substeps"),
        lambda d: d["drags"].append({"node": 0}),
    ),
    "tensegrity-naive-comparison": (
        lambda d: d["naive"][0].pop("fraction"),
        lambda d: d.__setitem__("method", "settle"),
        lambda d: d["designed"].__setitem__("slack_cables", -1),
        lambda d: d["designed"].__setitem__("status", "settled"),
    ),
    "tensegrity-check": (
        lambda d: d.__setitem__("verified", "yes"),
        lambda d: d.pop("problems"),
        lambda d: d.__setitem__("wrong_signs", -1),
        lambda d: d.__setitem__("status_claimed", "fine"),
    ),
}


def reports_in(written):
    """(path, document) of every document the program wrote, the naive
    comparison a design file embeds included; of a frames file its last frame."""
    for path in written:
        documents = documents_in(path)
        document = documents[-1]
        yield path, document
        if document.get("format") == "tensegrity-design" and "naive_comparison" in document.get("design", {}):
            yield path, document["design"]["naive_comparison"]


def check_live_new_formats(schemas, written):
    failures = 0
    seen = set()
    for path, document in reports_in(written):
        if document.get("format") == "tensegrity-design":
            if "naive_comparison" not in document.get("design", {}):
                continue
            broken = copy.deepcopy(document)
            broken["design"]["naive_comparison"]["naive"][0].pop("fraction")
            if not schemas.errors(broken):
                print(f"{path}: the design schema accepted a broken naive comparison")
                failures += 1
            continue
        mutations = BROKEN_COPIES.get(document.get("format"))
        if mutations is None:
            continue
        seen.add(document["format"])
        if schemas.errors(document):
            continue  # reported by check_files
        for number, mutate in enumerate(mutations):
            broken = copy.deepcopy(document)
            mutate(broken)
            if not schemas.errors(broken):
                print(f"{path}: the {document['format']} schema accepted broken copy {number}")
                failures += 1
    for missing in sorted(set(BROKEN_COPIES) - seen):
        print(f"no program output of format {missing} to break")
        failures += 1
    return failures


def check_live_reports(schemas, written):
    """The report schemas, too, must reject a broken copy of a report the program wrote."""
    failures = check_live_new_formats(schemas, written)
    for path in written:
        document = documents_in(path)[-1]
        if document.get("format") == "tensegrity-actuation":
            failures += check_live_actuation(schemas, path, document)
            continue
        if document.get("format") not in ("tensegrity-batch-report", "tensegrity-stress-report"):
            continue
        key = "jobs" if document["format"] == "tensegrity-batch-report" else "trials"
        if not document.get(key):
            print(f"{path}: no {key} to break")
            failures += 1
            continue
        for mutate in (
            lambda d: d[key][0].__setitem__("status", "finished"),
            lambda d: d[key][0].pop("solver"),
            lambda d: d[key][0].__setitem__("iterations", -1),
        ):
            broken = copy.deepcopy(document)
            mutate(broken)
            if not schemas.errors(broken):
                print(f"{path}: the {document['format']} schema accepted a broken copy")
                failures += 1
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=pathlib.Path, required=True, help="the repository")
    parser.add_argument("--binary", type=pathlib.Path, help="build/tensegrity: also validate what it writes")
    parser.add_argument("--validate", nargs="*", type=pathlib.Path, help="only these files")
    args = parser.parse_args()
    schemas = Schemas(args.source / "docs" / "schemas")
    if args.validate is not None:
        return 1 if check_files(schemas, args.validate) else 0

    failures = check_live(schemas, args.source)
    shipped = shipped_files(args.source)
    failures += check_files(schemas, shipped)
    written = []
    if args.binary:
        with tempfile.TemporaryDirectory(prefix="tensegrity-schema-") as work:
            written = program_outputs(args.source, args.binary, pathlib.Path(work))
            failures += check_files(schemas, written)
            failures += check_live_reports(schemas, written)
            failures += check_bad_poses(schemas, args.binary, pathlib.Path(work))
    else:
        failures += check_bad_poses(schemas, None, None)
    print(f"schema_test: {len(shipped)} shipped files, {len(written)} program outputs, {failures} mismatches")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
