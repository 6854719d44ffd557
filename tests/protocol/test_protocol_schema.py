"""docs/protocol.md's JSON Schemas are what `lab protocol schema --write` generates from the
structs of lab/protocol: a struct changed without the page fails here."""

from lab.protocol.schema import DOC, with_schemas


def test_the_documented_schemas_are_the_generated_ones() -> None:
    page = DOC.read_text()
    assert with_schemas(page) == page, "run `lab protocol schema --write`"
