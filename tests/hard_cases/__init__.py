"""Generated hard inputs shared by the tests: valid files of every format to break (``inputs``)
and hard terrains with what the tool must do on each (``terrains``). The tests that use them
sit beside what they harden (``tests/cli/test_malformed_input.py``, ``test_fuzz.py``,
``test_hard_terrains.py``)."""
