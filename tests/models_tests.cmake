# Tests of the virtual machine tool and the identification models (DBB).
guideway_add_test(machine_test SOURCES machine_test.cpp LIBS guideway_machine)
