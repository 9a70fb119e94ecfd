"""identify.core.serial: fields in, fields out; fit.json of version 1 still loads (migration)."""
from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np
import pytest

from identify.core.errors import InputError
from identify.core.serial import Schema, Serial, from_data, meta, to_data
from identify.fit.run import (
    FIT_SCHEMA,
    RECORD_DEFAULTS,
    SCHEMA,
    FitRun,
    FitSettings,
    InputFile,
    Provenance,
)


@dataclasses.dataclass(frozen=True)
class _Inner:
    x: float
    tags: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class _Outer:
    name: str
    inner: _Inner
    others: tuple[_Inner, ...] = ()
    limit: float | None = None
    table: dict[str, float] = dataclasses.field(default_factory=dict)


def test_a_dataclass_round_trips_field_by_field():
    obj = _Outer("a", _Inner(math.nan, ("p", "q")), (_Inner(1.5),), 2.0, {"k": 3.0})
    data = to_data(obj)
    assert data == {"name": "a", "inner": {"x": None, "tags": ["p", "q"]},
                    "others": [{"x": 1.5, "tags": []}], "limit": 2.0, "table": {"k": 3.0}}
    back = from_data(_Outer, data)
    assert math.isnan(back.inner.x)  # null reads back as NaN for a float field
    assert dataclasses.replace(back, inner=_Inner(0.0, ("p", "q"))) == dataclasses.replace(
        obj, inner=_Inner(0.0, ("p", "q")))


def test_a_missing_field_takes_its_default_and_an_unknown_one_is_refused():
    assert from_data(_Outer, {"name": "a", "inner": {"x": 1.0}}) == _Outer("a", _Inner(1.0))
    with pytest.raises(TypeError, match="unknown field"):
        from_data(_Outer, {"name": "a", "inner": {"x": 1.0}, "colour": "red"})


def test_migrations_run_in_order_and_an_unknown_version_is_refused():
    schema = Schema("demo", 3, {1: lambda d: {**d, "b": 1}, 2: lambda d: {**d, "c": d["b"] + 1}})
    doc = {"schema": "demo/1", "a": 0}
    assert schema.upgrade(doc) == {"schema": "demo/3", "a": 0, "b": 1, "c": 2}
    assert doc == {"schema": "demo/1", "a": 0}  # the input is not modified
    for bad in ({"schema": "demo/4"}, {"schema": "demo/0"}, {"schema": "other/3"}, {}):
        with pytest.raises(ValueError, match="expected 'demo/3'"):
            schema.upgrade(bad)


def test_the_provenance_records_round_trip():
    s = FitSettings(seed=3, only=("CFz",), hold=("PKY4",), mcmc_budget_s=None)
    assert FitSettings.from_dict(s.to_dict()) == s
    p = Provenance("0.1.0", "2020-01-01T00:00:00+00:00", "mfid fit x", 3, s,
                   (InputFile("x/tyre.toml", "ab" * 32),))
    assert Provenance.from_dict(p.to_dict()) == p
    assert list(p.to_dict()) == ["mfid_version", "created_utc", "command", "seed", "settings",
                                 "inputs"]


def _v1_document() -> dict:
    """A fit.json of the first layout: no entries recorded later, a plain-string key source,
    settings without the later settings, null provenance fields."""
    return {
        "schema": "mfid.fit/1",
        "tyre": {"id": "t1", "size": "225/50R17"},
        "provenance": {"mfid_version": None, "seed": None,
                       "settings": {"seed": 0, "only": ["CFz"]}},
        "fits": [],
        "tir": {"path": "t1.tir", "fittyp": 61, "key_sources": {"PFZ1": "CFz/mf"}},
    }


def test_a_version_1_fit_json_loads_through_the_migration():
    assert SCHEMA == FIT_SCHEMA.tag == "mfid.fit/2"
    run = FitRun.from_dict(_v1_document())
    settings = run.provenance.settings
    assert settings.mf_passes == RECORD_DEFAULTS["mf_passes"] == 1  # what such a fit ran with
    assert settings.segment is False and settings.only == ("CFz",)
    assert run.provenance.seed == 0 and run.provenance.mfid_version == ""
    assert run.key_sources["PFZ1"].supplied_by == "CFz/mf"
    assert run.failed == () and run.coverage == () and dict(run.data_quality) == {}
    doc = run.to_dict()
    assert doc["schema"] == "mfid.fit/2"
    assert FitRun.from_dict(doc).to_dict() == doc


def test_a_fit_json_of_another_schema_names_the_key():
    with pytest.raises(InputError, match="schema is 'mfid.fit/9', expected 'mfid.fit/2'"):
        FitRun.from_dict({"schema": "mfid.fit/9", "fits": []})


class _Colour(enum.Enum):
    RED = "red"
    BLUE = "blue"


@dataclasses.dataclass(frozen=True)
class _Hooked(Serial):
    index: int = dataclasses.field(metadata=meta(key="step"))
    dof: dict[str, float] = dataclasses.field(default_factory=dict,
                                              metadata=meta(null=math.inf))
    colour: _Colour = _Colour.RED
    curve: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0),
                                          metadata=meta(skip=True), compare=False)
    by_bar: dict[float, float] = dataclasses.field(default_factory=dict)
    by_bar_g: dict[float, float] = dataclasses.field(default_factory=dict,
                                                     metadata=meta(key_format="g"))

    serial_derived = {"n_dof": lambda self: len(self.dof)}


@dataclasses.dataclass(frozen=True)
class _Holder:
    hooked: tuple[_Hooked, ...]
    values: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0), compare=False)


def test_a_field_is_written_under_its_key_and_a_derived_key_is_ignored_on_read():
    h = _Hooked(3, {"a": math.inf, "b": 2.0}, _Colour.BLUE, np.ones(4), {1.9: 0.5},
                {2.0: 0.25})
    data = h.to_dict()
    assert data == {"step": 3, "dof": {"a": None, "b": 2.0}, "colour": "blue",
                    "by_bar": {"1.9": 0.5}, "by_bar_g": {"2": 0.25},
                    "n_dof": 2}  # curve is not written
    back = _Hooked.from_dict(data)
    assert back == dataclasses.replace(h, curve=np.zeros(0))
    assert back.dof["a"] == math.inf  # null reads as the field's null value
    assert back.curve.size == 0 and back.by_bar == {1.9: 0.5} and back.by_bar_g == {2.0: 0.25}
    with pytest.raises(TypeError, match="missing field.*step"):
        _Hooked.from_dict({"dof": {}})


def test_nested_classes_keep_their_hooks_and_arrays_become_lists():
    obj = _Holder((_Hooked(1),), np.array([1.0, np.nan, np.float32(2.5)]))
    data = to_data(obj)
    assert data["hooked"] == [{"step": 1, "dof": {}, "colour": "red", "by_bar": {},
                               "by_bar_g": {}, "n_dof": 0}]
    assert data["values"] == [1.0, None, 2.5]
    back = from_data(_Holder, data)
    assert back.hooked == obj.hooked
    np.testing.assert_array_equal(back.values, obj.values)  # null reads back as NaN


@dataclasses.dataclass(frozen=True)
class _Ordered(Serial):
    a: int
    b: int
    c: int = 0

    serial_derived = {"total": lambda self: self.a + self.b + self.c}
    serial_order = ("c", "total")


def test_the_keys_named_first_lead_the_document_the_others_follow_in_field_order():
    assert list(_Ordered(1, 2, 3).to_dict().items()) == [("c", 3), ("total", 6), ("a", 1),
                                                         ("b", 2)]
    assert _Ordered.from_dict({"c": 3, "total": 99, "a": 1, "b": 2}) == _Ordered(1, 2, 3)


def test_a_null_tyre_text_of_version_1_reads_as_its_default_and_the_tir_path_follows_the_id():
    doc = _v1_document()
    doc["tyre"] = {"id": "t1", "size": None, "nominal_load_N": None}
    del doc["tir"]["path"]
    run = FitRun.from_dict(doc)
    assert run.tyre.size == "" and math.isnan(run.tyre.nominal_load_N)
    assert run.tir_name == "t1.tir" and run.fittyp == 61


def test_an_unknown_key_in_a_fit_entry_is_refused_naming_the_entry():
    doc = FitRun.from_dict(_v1_document()).to_dict()
    doc["tir"]["forms"] = [{"relation": "CFx", "form": "f", "simpler": "a", "richer": "b",
                            "criterion": "F", "reason": "r", "colour": "red"}]
    with pytest.raises(InputError, match="tir.*unknown field.*colour"):
        FitRun.from_dict(doc)
