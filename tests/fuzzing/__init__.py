"""Fuzzers of mocapkit: the readers (:mod:`tests.fuzzing.readers`) and whole commands (:mod:`tests.fuzzing.commands`).

They live beside the tests, not in the installed package: they fork, set
resource limits (POSIX only) and run the CLI in subprocesses. The tests import
them as ``tests.fuzzing``; the benchmarks ``benchmarks/fuzz_readers.py`` and
``benchmarks/fuzz_commands.py`` put the repository root on ``sys.path`` first.
"""
