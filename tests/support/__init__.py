"""What the tests share: servers, clocks, counters, browser pages, database fixtures.

A test module (test_*.py) imports helpers from here and names fixtures, which
tests/conftest.py registers from here (`pytest_plugins`); it never imports another
test module (tests/test_architecture.py checks that).
"""
