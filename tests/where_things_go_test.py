#!/usr/bin/env python3
"""docs/architecture.md "Where a new thing goes", checked where a script can: each kind of addition is
in the one table it claims to need, and nowhere else is a list to keep in step.

Usage: where_things_go_test.py [ROOT]
"""
import pathlib
import re
import sys
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)


def text(path):
    return (ROOT / path).read_text()


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
        for name in registered:
            self.assertIn(name, folders, f"drivers/{name} is in drivers/CMakeLists.txt")
            self.assertTrue((ROOT / "drivers" / name / "CMakeLists.txt").exists())
        for folder in folders:
            self.assertTrue((ROOT / "drivers" / folder).is_dir(), f"drivers/{folder}")

    def test_every_built_in_driver_is_its_protocol_on_the_skeleton(self):
        """The loop's timer and hooks, the link's back-off and the rest schedule are the skeleton's
        (drivers/loop_driver.hpp): an instrument's folder touches none of them."""
        registered = re.findall(r"&(\w+)::register_\w+_driver", text("drivers/builtin.cpp"))
        self.assertTrue(registered)
        loop_words = re.compile(r"add_timer|add_wake_hook|add_settle_hook|remove_hook|->arm\(|\.arm\(|->watch\(|"
                                r"->modify\(|LoopConnector|default_read_period_us \*")
        for name in registered:
            header = text(f"drivers/{name}/{name}_driver.hpp")
            self.assertTrue("public drivers::LoopDriver" in header, f"drivers/{name}: not on the skeleton")
            for source in sorted((ROOT / "drivers" / name).glob("*.[ch]pp")):
                for number, line in enumerate(source.read_text().splitlines(), 1):
                    self.assertIsNone(loop_words.search(line), f"{source.relative_to(ROOT)}:{number}: loop policy "
                                      f"outside the skeleton: {line.strip()}")

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
