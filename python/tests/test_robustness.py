"""Bad arrays and options raise clean exceptions that carry the library's message; nothing crashes."""
import numpy as np
import pytest

import epsnet

from conftest import square


def test_vertices_of_the_wrong_shape_are_a_value_error():
    v, f = square()
    for bad in (v[:, :2], v.reshape(-1), v.reshape(1, 4, 3), np.zeros((4, 4))):
        with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
            epsnet.simplify(bad, f)


def test_faces_of_the_wrong_shape_are_a_value_error():
    v, f = square()
    for bad in (f[:, :2], f.reshape(-1), np.zeros((2, 4), dtype=np.int64)):
        with pytest.raises(ValueError, match=r"shape \(m, 3\)"):
            epsnet.simplify(v, bad)


def test_unsupported_dtypes_are_a_value_error_not_a_silent_conversion():
    v, f = square()
    for bad in (v.astype(np.float16), v.astype(np.int64), v.astype(np.complex128), v.astype(object)):
        with pytest.raises(ValueError, match="float32 or float64"):
            epsnet.simplify(bad, f)
    for bad in (f.astype(np.uint32), f.astype(np.int16), f.astype(np.float64)):
        with pytest.raises(ValueError, match="int32 or int64"):
            epsnet.simplify(v, bad)


def test_out_of_range_and_negative_indices_name_their_row():
    v, f = square()
    for value in (4, -1, 2**40, -(2**31)):
        bad = f.copy()
        bad[1, 2] = value
        with pytest.raises(ValueError, match=rf"faces\[1, 2\] = {value} is not a vertex index \(0 \.\. 3\)") as e:
            epsnet.simplify(v, bad)
        assert isinstance(e.value, epsnet.FormatError)
        assert e.value.reason.startswith("faces[1, 2]")
    with pytest.raises(ValueError, match=r"faces\[0, 0\] = -5"):
        epsnet.simplify(v.astype(np.float32), np.array([[-5, 1, 2]], dtype=np.int32))


def test_nan_and_infinite_coordinates_name_their_row():
    v, f = square()
    for value in (np.nan, np.inf, -np.inf):
        bad = v.copy()
        bad[2, 1] = value
        with pytest.raises(ValueError, match=r"vertices\[2\] is not finite"):
            epsnet.simplify(bad, f)
        with pytest.raises(ValueError, match=r"vertices\[2\] is not finite"):
            epsnet.sample(bad, f)


def test_empty_arrays_are_refused_cleanly():
    v, f = square()
    empty_v, empty_f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    with pytest.raises(ValueError, match="faces is empty"):
        epsnet.simplify(v, empty_f)
    with pytest.raises(ValueError, match="faces is empty"):
        epsnet.sample(empty_v, empty_f)
    with pytest.raises(ValueError, match="names a vertex, but there are none"):
        epsnet.simplify(empty_v, f)
    with pytest.raises(ValueError, match="undefined"):
        epsnet.hausdorff((v, f), (v, empty_f))


def test_bad_options_are_value_errors():
    v, f = square()
    cases = [
        dict(ratio=0), dict(ratio=1.5), dict(ratio="half"), dict(face_count=0), dict(face_count=1.5),
        dict(ratio=0.5, face_count=1), dict(error=-1.0), dict(threads=-2), dict(mem="lots"),
        dict(rotation="sideways"), dict(seed=1, rotation="identity"), dict(level=-3), dict(face_count=10**6),
    ]
    for options in cases:
        with pytest.raises(ValueError):
            epsnet.simplify(v, f, **options)


def test_bad_attributes_are_value_errors():
    v, f = square()
    for attributes, says in [
        ({"c": np.zeros(3)}, r"shape \(4,\)"),
        ({"c": np.zeros((4, 3))}, "its own name"),
        ({"c": np.zeros(4, dtype=np.int64)}, "PLY types"),
        ({"has space": np.zeros(4)}, "white space"),
        ({"": np.zeros(4)}, "empty"),
        ([np.zeros(4)], "dict"),
    ]:
        with pytest.raises(ValueError, match=says):
            epsnet.simplify(v, f, attributes=attributes)
    with pytest.raises(ValueError, match="not one of the attributes"):
        epsnet.simplify(v, f, lock="lock")


def test_the_extension_checks_what_it_is_given_directly():
    # the package checks first; the extension must not trust it
    from epsnet import _epsnet

    v, f = square()
    with pytest.raises(ValueError, match="C-contiguous"):
        _epsnet.simplify(np.asfortranarray(v), f, None, {}, None)
    with pytest.raises(ValueError, match="numpy array"):
        _epsnet.simplify([[0, 0, 0]], f, None, {}, None)
    with pytest.raises(ValueError, match="float32 or float64"):
        _epsnet.simplify(v.astype(np.int64), f, None, {}, None)
    with pytest.raises(ValueError, match="int32 or int64"):
        _epsnet.simplify(v, f.astype(np.uint64), None, {}, None)
    with pytest.raises(ValueError, match="level"):
        _epsnet.simplify(v, f, None, {"level": "three"}, None)


def test_an_unreadable_file_is_an_os_error_and_a_malformed_one_a_value_error(tmp_path):
    with pytest.raises(OSError, match="nonexistent.ply") as e:
        epsnet.simplify_file(tmp_path / "nonexistent.ply", tmp_path / "out.ply")
    assert isinstance(e.value, epsnet.FileError) and e.value.file.endswith("nonexistent.ply")
    with pytest.raises(OSError):
        epsnet.read_mesh(tmp_path / "nonexistent.obj")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                    b"element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n3 0 1 7\n")
    with pytest.raises(ValueError) as e:
        epsnet.simplify_file(bad, tmp_path / "out.ply")
    assert isinstance(e.value, epsnet.FormatError) and e.value.line is not None
    assert "bad.ply" in str(e.value)
    assert not (tmp_path / "out.ply").exists()


def test_non_contiguous_and_byte_swapped_input_is_copied_and_gives_the_same_result(gen_mesh):
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 4000))
    ref_v, ref_f = epsnet.simplify(v, f)
    wide = np.zeros((len(v), 6), dtype=v.dtype)
    wide[:, ::2] = v
    swapped = f.astype(f.dtype.newbyteorder(">"))
    got_v, got_f = epsnet.simplify(wide[:, ::2], swapped)
    assert np.array_equal(got_v, ref_v) and np.array_equal(got_f, ref_f)
