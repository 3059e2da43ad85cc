#!/usr/bin/env python3
"""docs/architecture.md "Where a new thing goes", checked where a script can: each kind of addition is
in the one table it claims to need, and nowhere else is a list to keep in step.

Usage: where_things_go_test.py [ROOT]
"""
import pathlib
import re
import sys
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])


def text(path):
    return (ROOT / path).read_text()


# The folders of the code, and all of the tree's own (not its build trees): where a file the table names by its
# name alone is looked for.
CODE_FOLDERS = ("core", "dsp", "formats", "results", "models", "drivers", "plant", "report", "simulators", "sessions",
                "fleet", "daemon", "cli")
SOURCE_FOLDERS = CODE_FOLDERS + ("config", "docs", "scripts", "tests", "bench", "linuxcnc")


def table_rows():
    """docs/architecture.md's table: {kind of addition: its "files that change" cell}."""
    section = text("docs/architecture.md").split("## Where a new thing goes", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith("| new ..."):
            kind, files = (c.strip() for c in line.strip().strip("|").split("|", 1))
            rows[kind] = files
    return rows


def expand(pattern):
    """`sessions/<kind>_session.{hpp,cpp}` -> ["sessions/*_session.hpp", "sessions/*_session.cpp"]."""
    pattern = re.sub(r"<[^>]+>", "*", pattern)
    m = re.search(r"\{([^}]*)\}", pattern)
    if not m:
        return [pattern]
    return [p for alt in m.group(1).split(",") for p in expand(pattern[:m.start()] + alt + pattern[m.end():])]


class WhereThingsGo(unittest.TestCase):
    def test_every_effect_file_is_one_line_of_the_library_table(self):
        files = sorted(p.stem for p in (ROOT / "models/explain/effects").glob("*.cpp") if p.stem != "dbb_terms")
        table = text("models/explain/effects.cpp")
        for name in files:
            source = text(f"models/explain/effects/{name}.cpp")
            self.assertIn(f"extern const Effect {name}{{", source, f"{name}.cpp defines the effect {name}")
            self.assertIn(f'{{"{name}",', source, f"{name}.cpp: its library entry is named {name}")
            self.assertEqual(len(re.findall(rf"&{name},", table)), 1, f"effects.cpp lists {name} once")
        self.assertEqual(len(re.findall(r"^\s+&\w+,$", table, re.M)), len(files), "the table lists only effect files")
        self.assertIn("effects/*.cpp", text("models/explain/CMakeLists.txt"), "effect files need no CMake line")

    def test_every_effect_dbb_checked_lists_is_an_effect(self):
        """dbb_checked.cpp's lists (held by identify's models, never fitted beside) name effects by their
        library name: a renamed or removed effect must not leave a name that matches nothing."""
        source = text("models/explain/dbb_checked.cpp")
        effects = {p.stem for p in (ROOT / "models/explain/effects").glob("*.cpp")}
        for name in ("held_by_both", "held_by_diagnostics", "not_beside"):
            m = re.search(rf"constexpr std::string_view {name}\[\] = \{{([^}}]*)\}};", source)
            self.assertIsNotNone(m, f"dbb_checked.cpp has its list {name}")
            listed = re.findall(r'"(\w+)"', m.group(1))
            self.assertTrue(listed, name)
            for effect in listed:
                self.assertIn(effect, effects, f"dbb_checked.cpp's {name} lists {effect}: no effects/{effect}.cpp")

    def test_every_session_kind_has_its_session_and_registration(self):
        kinds = re.findall(r'inline constexpr SessionKindInfo (\w+)_kind\{\s*"(\w+)"', text("results/session_kinds.hpp"))
        self.assertTrue(kinds)
        table = text("results/session_kinds.cpp")
        registry = text("sessions/session_kinds.cpp")
        for symbol, name in kinds:
            self.assertEqual(symbol, name)
            self.assertIn(f"&{name}_kind", table, f"results/session_kinds.cpp lists {name}")
            self.assertTrue((ROOT / f"sessions/{name}_session.cpp").exists(), f"sessions/{name}_session.cpp")
            self.assertIn(f"registry.add({name}_session_kind());", registry, f"sessions/session_kinds.cpp registers {name}")
            session = text(f"sessions/{name}_session.cpp")
            self.assertIn(f"results::{name}_kind", session, f"the {name} session takes its name and options from results/")
        self.assertEqual(len(re.findall(r"registry\.add\(", registry)), len(kinds), "every registered kind is in results/")
        self.assertIn("*_session.cpp", text("sessions/CMakeLists.txt"), "session files need no CMake line")

    def test_every_input_kind_of_the_report_has_its_chain(self):
        """A session kind's files reach its report through report/'s chain: the InputKind, its name, its
        recognition, its section and its case in render_report."""
        enum = re.search(r"enum class InputKind \{([^}]*)\}", text("report/report.hpp")).group(1)
        kinds = [k.strip() for k in enum.split(",") if k.strip()]
        self.assertGreaterEqual(len(kinds), 7)
        source = text("report/report.cpp")
        kind_name = re.search(r"std::string_view kind_name\(InputKind kind\) \{(.*?)\n\}", source, re.S).group(1)
        detect = re.search(r"InputKind detect_input\(const std::string& path\) \{(.*?)\n\}", source, re.S).group(1)
        render = re.search(r"std::string render_report\(.*?\n\}", source, re.S).group(0)
        sections = text("report/sections.hpp")
        cmake = text("report/CMakeLists.txt")
        for k in kinds:
            self.assertIn(f"case InputKind::{k}:", kind_name, f"kind_name names {k}")
            self.assertIn(f"return InputKind::{k};", detect, f"detect_input recognises {k}")
            case = re.search(rf"case InputKind::{k}:(.*?)(?=case InputKind::|\n    \}})", render, re.S)
            self.assertIsNotNone(case, f"render_report has a case for {k}")
            called = re.findall(r"\b(\w+_section)\(", case.group(1))
            self.assertTrue(called, f"render_report's case {k} renders a section")
            for section in called:
                self.assertRegex(sections, rf"std::string {section}\(", f"{section} in report/sections.hpp")
                defined = [p for p in (ROOT / "report").glob("*.cpp") if re.search(rf"^std::string {section}\(",
                                                                                  p.read_text(), re.M)]
                self.assertEqual(len(defined), 1, f"{section} defined once in report/")
                self.assertIn(defined[0].name, cmake, f"{defined[0].name} in report/CMakeLists.txt")

    def test_every_parameter_constant_is_in_the_catalogue(self):
        names = re.findall(r"inline constexpr Parameter (\w+)\{", text("results/parameters.hpp"))
        self.assertGreater(len(names), 50)
        catalogue = text("results/parameters.cpp")
        for name in names:
            self.assertEqual(len(re.findall(rf"&{name}\b", catalogue)), 1, f"{name} once in catalogue()")

    def test_every_message_class_is_in_the_table_and_the_protocol(self):
        header = text("results/message_class.hpp")
        enum = re.search(r"enum class MessageClass \{([^}]*)\}", header).group(1)
        classes = [c.strip() for c in enum.split(",") if c.strip()]
        table = text("results/message_class.cpp")
        protocol = text("docs/protocol.md")
        for c in classes:
            m = re.search(rf'ClassName\{{MessageClass::{c}, "([A-Z]+)"', table)
            self.assertIsNotNone(m, f"the table names MessageClass::{c}")
            doc = protocol if c != "port" else text("docs/cli.md")
            self.assertIn(f'"class":"{m.group(1)}"', doc.replace(" ", ""), f"{m.group(1)} documented")
        requests = re.search(r"enum class RequestClass \{([^}]*)\}", header).group(1)
        for r in [c.strip() for c in requests.split(",") if c.strip()]:
            self.assertIn(f'RequestName{{RequestClass::{r}, "{r}"}}', table)
            self.assertIn(f"{{RequestClass::{r}, &Daemon::", text("daemon/daemon.cpp"), f"the daemon handles {r}")

    def test_every_instrument_folder_is_built_and_built_in(self):
        cmake = text("drivers/CMakeLists.txt")
        folders = re.search(r"foreach\(dir ([^)]*)\)", cmake).group(1).split()
        builtin = text("drivers/builtin.cpp")
        registered = re.findall(r"&(\w+)::register_\w+_driver", builtin)
        linked = re.search(r"target_link_libraries\(guideway_builtin_drivers ([^)]*)\)", cmake).group(1).split()
        for name in registered:
            self.assertIn(name, folders, f"drivers/{name} is in drivers/CMakeLists.txt")
            self.assertIn(f"add_library(guideway_{name} ", text(f"drivers/{name}/CMakeLists.txt"))
            self.assertIn(f"guideway_{name}", linked, f"guideway_builtin_drivers links guideway_{name}")
        self.assertIn("\n## A built-in loop-driven driver\n", text("docs/plugins.md"), "the contract a driver implements")
        for folder in folders:
            self.assertTrue((ROOT / "drivers" / folder).is_dir(), f"drivers/{folder}")

    def test_a_message_class_is_compared_by_its_enum_outside_results(self):
        """results/message_class is the one place a class's wire name is written: elsewhere a class is compared
        through MessageClass (to_string, has_class), never with its text ("EXPLAIN")."""
        table = text("results/message_class.cpp")
        names = "|".join(re.findall(r'ClassName\{MessageClass::\w+, "([A-Z]+)"', table))
        self.assertIn("EXPLAIN", names)
        compared = re.compile(rf'(==|!=)\s*"({names})"|"({names})"\s*(==|!=)')
        for folder in (f for f in CODE_FOLDERS if f != "results"):
            for source in sorted((ROOT / folder).rglob("*.[ch]pp")):
                for number, line in enumerate(source.read_text().splitlines(), 1):
                    self.assertIsNone(compared.search(line), f"{source.relative_to(ROOT)}:{number}: a message class "
                                      f"compared by its text: {line.strip()}")

    def test_every_emulated_instrument_reads_the_machine_and_runs_by_default(self):
        """An instrument's emulator reads the virtual machine (simulators/machine) and guidewayd's default
        configuration (config/default.toml) starts it beside its device, whose driver is built in."""
        import tomllib
        emulators = ROOT / "simulators/emulators"
        instruments = {}
        for source in sorted(emulators.glob("*_command.cpp")):
            body = source.read_text()
            for name in re.findall(r'add_subcommand\(\s*"(\w+)"', body):
                instruments[name] = source
        self.assertGreaterEqual(len(instruments), 4)
        registered = re.findall(r"&(\w+)::register_\w+_driver", text("drivers/builtin.cpp"))
        drivers = set()
        for folder in registered:
            for source in (ROOT / "drivers" / folder).glob("*.cpp"):
                drivers.update(re.findall(r'registry\.add\(\s*"([\w-]+)"', source.read_text()))
        self.assertEqual(len(drivers), len(registered), drivers)
        config = tomllib.loads(text("config/default.toml"))
        started = [e["instrument"] for e in config["emulator"]]
        devices = [d["driver"] for d in config["device"]]
        self.assertEqual(len(started), len(devices), "one emulator a device")
        for driver in devices:
            self.assertIn(driver, drivers, f"config/default.toml: {driver} is a built-in driver")
        for name in started:
            self.assertIn(name, instruments, f"config/default.toml: guideway-emulate {name}")
        machine = re.compile(r'#include "simulators/(machine/\w+|emulators/\w*machine_sources?)\.hpp"')
        # The row's examples of what an instrument adds to the virtual machine: its query and its set-up table.
        for query in ("runout_sample", "facing_profile"):
            self.assertRegex(text("simulators/machine/machine.hpp"), rf"\b{query}\(", f"Machine::{query}")
        self.assertIn('top.table("autocollimator")', text("simulators/machine/machine_config.cpp"))
        self.assertIn("\n[autocollimator]", text("config/machine-example.toml"))
        for name, source in instruments.items():
            if source.name == "measurement_files_command.cpp":  # files of a day's tests, no transport
                continue
            self.assertIsNotNone(machine.search(source.read_text()), f"{source.name}: {name} reads the virtual machine")
            self.assertIn(name, started, f"config/default.toml starts guideway-emulate {name}")

    def test_every_built_in_driver_is_its_protocol_on_the_skeleton(self):
        """The loop's timer and hooks, the link's back-off (and its keys) and the rest schedule are the
        skeleton's (drivers/loop_driver.hpp): an instrument's folder touches none of them, and runs no
        thread of its own with a connect loop."""
        registered = re.findall(r"&(\w+)::register_\w+_driver", text("drivers/builtin.cpp"))
        self.assertTrue(registered)
        loop_words = re.compile(r"add_timer|add_wake_hook|add_settle_hook|remove_hook|->arm\(|\.arm\(|->watch\(|"
                                r"->modify\(|LoopConnector|default_read_period_us \*|"
                                r"backoff\(\)|take_ns\(|take_s\(|sleep_for\(|std::stop_token|void run\(|"
                                r'"reconnect_m(in|ax)_ms"|"backoff_(initial|max)_ms"')
        for name in registered:
            header = text(f"drivers/{name}/{name}_driver.hpp")
            self.assertTrue("public drivers::LoopDriver" in header, f"drivers/{name}: not on the skeleton")
            for source in sorted((ROOT / "drivers" / name).glob("*.[ch]pp")):
                for number, line in enumerate(source.read_text().splitlines(), 1):
                    self.assertIsNone(loop_words.search(line), f"{source.relative_to(ROOT)}:{number}: loop policy "
                                      f"outside the skeleton: {line.strip()}")

    def test_every_file_the_table_names_exists(self):
        """A path (`report/report.cpp`, `drivers/<name>/`) exists; a `<placeholder>` is at least one of its kind
        (`report/<kind>_section.cpp`: some report/*_section.cpp); a file named alone (`<name>_command.cpp`,
        `can.cmake`) exists in some folder of the tree; a linked document is in docs/."""
        rows = table_rows()
        self.assertGreaterEqual(len(rows), 9)
        file_name = re.compile(r"^[\w.<>{},-]+\.(\{[\w,]+\}|cpp|hpp|h|cmake|toml|md|txt|py)$")
        for kind, cell in rows.items():
            named = re.findall(r"`([^`\s]+)`", cell)
            paths = [n for n in named if "/" in n and "*" not in n and not n.startswith("guideway/")]
            paths += re.findall(r"\b(docs/[\w-]+\.md)\b", cell)
            self.assertTrue(paths, f"the row '{kind}' names no file")
            for path in paths:
                found = [f for p in expand(path) for f in ROOT.glob(p.rstrip("/"))]
                self.assertTrue([f for f in found if f.is_dir() or not path.endswith("/")],
                                f"'{kind}': {path} does not exist")
            for link in re.findall(r"\]\(([\w-]+\.md)", cell):
                self.assertTrue((ROOT / "docs" / link).exists(), f"'{kind}': docs/{link} does not exist")
            for name in (n for n in named if "/" not in n and file_name.match(n)):
                self.assertTrue(any(next((ROOT / f).rglob(p), None) for f in SOURCE_FOLDERS for p in expand(name)),
                                f"'{kind}': no file {name} in the tree")

    def test_every_emulated_instrument_is_in_one_emulator_group(self):
        """An instrument's `guideway-emulate` subcommand is built by exactly one emulator group's .cmake
        (picked up by simulators/emulators/CMakeLists.txt's glob)."""
        emulators = ROOT / "simulators/emulators"
        self.assertIn("*.cmake", text("simulators/emulators/CMakeLists.txt"))
        groups = {p.name: p.read_text() for p in emulators.glob("*.cmake")}
        commands = [p.name for p in emulators.glob("*_command.cpp") if p.name != "emulator_command.cpp"]
        self.assertGreaterEqual(len(commands), 4)
        for command in commands:
            owners = [g for g, body in groups.items() if re.search(rf"/{re.escape(command)}\b", body)]
            self.assertEqual(len(owners), 1, f"{command} is built by one emulator group: {owners}")

    def test_every_test_folder_is_a_folder_of_the_tree_and_in_the_build(self):
        """A test lives in the folder of the tree it tests (tests/<folder>/, tests/models/<model>/), which its
        parent's CMakeLists.txt adds; besides them only what the folders share (tests/support, tests/data,
        tests/golden) and the checks of the tree as a whole (tests/tree): no test lies loose in tests/."""
        shared = {"support", "data", "golden"}
        for parent, tree in (("tests", ROOT), ("tests/models", ROOT / "models")):
            added = re.search(r"foreach\(dir ([^)]*)\)", text(f"{parent}/CMakeLists.txt")).group(1).split()
            folders = sorted(p.name for p in (ROOT / parent).iterdir()
                             if p.is_dir() and not p.name.startswith(("_", ".")))
            self.assertGreaterEqual(len(folders), 7, parent)
            for folder in folders:
                if parent == "tests" and folder in shared:
                    self.assertNotIn(folder, added, f"{parent}/{folder} holds no tests of its own")
                    continue
                self.assertIn(folder, added, f"{parent}/CMakeLists.txt adds {parent}/{folder}")
                self.assertTrue((ROOT / parent / folder / "CMakeLists.txt").exists(),
                                f"{parent}/{folder}/CMakeLists.txt")
                self.assertTrue(folder == "tree" or (tree / folder).is_dir(),
                                f"{parent}/{folder} is no folder of the tree")
        loose = sorted(p.name for p in (ROOT / "tests").iterdir() if p.is_file() and p.name != "CMakeLists.txt")
        self.assertEqual(loose, [], "tests/ holds folders only")

    def test_every_file_format_is_built_and_documented(self):
        """formats/ lists its sources in its CMakeLists.txt; every `guideway/<name>/<version>` the code reads or
        writes, in formats/ or beside its one user, is in docs/formats.md."""
        cmake = text("formats/CMakeLists.txt")
        for source in (ROOT / "formats").glob("*.cpp"):
            self.assertTrue(re.search(rf"\b{re.escape(source.name)}\b", cmake), f"formats/CMakeLists.txt: {source.name}")
        formats = text("docs/formats.md")
        ids = set()
        for folder in CODE_FOLDERS:
            for source in (ROOT / folder).rglob("*.[ch]pp"):
                ids.update(re.findall(r"\bguideway/[a-z0-9-]+/\d+\b", source.read_text()))
        self.assertGreaterEqual(len(ids), 10)
        for format_id in sorted(ids):
            self.assertTrue(re.search(rf"(?<![\w-]){re.escape(format_id)}(?!\d)", formats), f"docs/formats.md: {format_id}")

    def test_every_mqtt_topic_is_named_accepted_stored_and_documented(self):
        enum = re.search(r"enum class TopicLeaf \{([^}]*)\}", text("plant/topics.hpp")).group(1)
        leaves = [leaf.strip() for leaf in enum.split(",") if leaf.strip()]
        self.assertGreaterEqual(len(leaves), 5)
        names = re.search(r"leaf_names = \{([^}]*)\}", text("plant/topics.cpp")).group(1)
        self.assertEqual(re.findall(r'"(\w+)"', names), leaves, "topics.cpp's leaf_names in the enum's order")
        mqtt = text("docs/protocol.md").split("\n## MQTT", 1)[1].split("\n## ", 1)[0]
        for leaf in leaves:
            for source in ("fleet/payload_check.cpp", "fleet/store.cpp"):
                self.assertTrue(f"case plant::TopicLeaf::{leaf}:" in text(source), f"{source} handles the topic {leaf}")
            self.assertTrue(re.search(rf"\| `PREFIX/MACHINE/{leaf}(/KIND)?` \|", mqtt), f"docs/protocol.md MQTT: {leaf}")

    def test_every_command_group_has_its_cmake(self):
        for source in (ROOT / "cli").glob("*_commands.cpp"):
            if source.name == "daemon_commands.cpp":  # the client's own commands, in cli/CMakeLists.txt
                self.assertIn(source.name, text("cli/CMakeLists.txt"))
                continue
            cmake = source.with_suffix(".cmake")
            self.assertTrue(cmake.exists(), f"{cmake.name} beside {source.name}")
            self.assertIn(source.name, cmake.read_text())
            self.assertIn("CommandGroup", source.read_text(), f"{source.name} registers itself")


if __name__ == "__main__":
    unittest.main()
