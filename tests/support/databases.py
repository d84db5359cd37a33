"""The databases the suite runs on."""

#: PostgreSQL's base URL for the tests (e.g. postgresql+psycopg://postgres@127.0.0.1:5432/test):
#: when set, every test that takes `database_url` runs on it too, in a schema of its own.
PG_ENV = "HCSS_TEST_DATABASE_URL"
