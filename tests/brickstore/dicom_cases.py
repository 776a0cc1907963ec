"""DICOM test inputs written at test time with pydicom (run with Debian's /usr/bin/python3), and the values pydicom
computes for them, for tests/brickstore/test_dicom_hospital.cpp. Nothing it writes is committed.

  dicom_cases.py study DIR      a study folder as a hospital exports it: a 5-slice CT series, pydicom's MR_small (a
                                second series), an RT plan, an RT structure set (no meta header), structured reports,
                                a waveform and a presentation state; DIR/medium/DICOMDIR indexes a copy of its images
  dicom_cases.py enhanced DIR   one volume as single-slice CT files (DIR/slices) and as one Enhanced CT file with its
                                frames shuffled (DIR/enhanced.dcm); the same as MR (DIR/mr, DIR/enhanced_mr.dcm);
                                refusal variants beside it (DIR/bad/*.dcm)
  dicom_cases.py dose DIR       RT dose grids (32-bit relative offsets, 16-bit absolute descending offsets, and
                                pydicom's rtdose.dcm), each with NAME.f64 (values in Gy, as the reader must order
                                them: along the slice normal) and NAME.json (dims, spacing, origin in RAS); refusal
                                variants beside them (DIR/bad/*.dcm)
  dicom_cases.py nometa DIR     pydicom's CT_small.dcm as is, without preamble and meta header (implicit VR), and
                                with a meta header but no preamble; pydicom's damaged no_meta.dcm
  dicom_cases.py pixels DIR     pydicom's MR_small.dcm in every transfer syntax pydicom ships it in, one folder each
                                (DIR/NAME/NAME.dcm), and DIR/MR_small.f64: pixel_array rescaled, as pydicom reads it
  dicom_cases.py pacs DIR       series to upload to a PACS, each folder one series, every file named by its
                                SOPInstanceUID as a DICOMweb fetch names it (tests/dicomweb): DIR/ct (a 5-slice CT
                                series holding an RT plan and a structured report too), DIR/plan and DIR/report (an
                                RT plan and a report in series of their own in the CT's study), DIR/enhanced (an
                                Enhanced CT file), DIR/two/a and DIR/two/b (two CT series of one study), DIR/big (two
                                2048x2048 slices of noise, 8 MB each), DIR/many (a CT series of 160 small slices, more
                                than a search capped at 100 lists); DIR/uids.json names their studies and series
Prints one line per written case.
"""
import copy
import json
import os
import random
import shutil
import sys

import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, ImplicitVRLittleEndian, generate_uid

TEST_FILES = os.path.join(os.path.dirname(pydicom.__file__), "data", "test_files")
CT_IMAGE = "1.2.840.10008.5.1.4.1.1.2"
ENHANCED_CT = "1.2.840.10008.5.1.4.1.1.2.1"
MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4"
ENHANCED_MR = "1.2.840.10008.5.1.4.1.1.4.1"
RT_DOSE = "1.2.840.10008.5.1.4.1.1.481.2"
GSPS = "1.2.840.10008.5.1.4.1.1.11.1"


def base(sop_class, series_uid, study_uid, modality):
    ds = Dataset()
    ds.file_meta = FileMetaDataset()
    ds.file_meta.MediaStorageSOPClassUID = sop_class
    ds.SOPInstanceUID = generate_uid()
    ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
    ds.file_meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds.is_little_endian, ds.is_implicit_VR = True, False
    ds.SOPClassUID = sop_class
    ds.StudyInstanceUID, ds.SeriesInstanceUID = study_uid, series_uid
    ds.Modality = modality
    ds.PatientName, ds.PatientID = "Test^Hospital", "HOSP1"
    ds.StudyDate, ds.StudyTime, ds.StudyID, ds.AccessionNumber = "20261128", "120000", "1", ""
    ds.SeriesNumber, ds.InstanceNumber = 1, 1
    ds.PatientBirthDate, ds.PatientSex, ds.ReferringPhysicianName = "", "", ""
    return ds


def pixel_module(ds, rows, columns, bits, signed, frames=None):
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.Rows, ds.Columns = rows, columns
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = bits, bits, bits - 1, int(signed)
    if frames is not None:
        ds.NumberOfFrames = frames


def save(ds, path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    ds.save_as(path, write_like_original=False)
    print(path)


def volume(nz, ny, nx):
    """A signed 16-bit volume distinct at every voxel."""
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return (x * 7 + y * 131 + z * 1009 - 2000).astype(np.int16)


# Geometry shared by the enhanced cases: a coronal volume (rows run right-to-left in LPS x, columns run inferior).
ROW, COLUMN = [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]
NORMAL = list(np.cross(ROW, COLUMN))  # (0, 1, 0): posterior
ORIGIN, SPACING, STEP = np.array([-40.0, 12.0, 80.0]), [0.8, 0.6], 2.5


def position(k):
    return [float(v) for v in ORIGIN + k * STEP * np.array(NORMAL)]


def write_slices(vol, directory, series_uid, study_uid, modality="CT"):
    for k in range(vol.shape[0]):
        ds = base(CT_IMAGE if modality == "CT" else MR_IMAGE, series_uid, study_uid, modality)
        ds.InstanceNumber = k + 1
        pixel_module(ds, vol.shape[1], vol.shape[2], 16, vol.dtype == np.int16)
        ds.ImagePositionPatient, ds.ImageOrientationPatient = position(k), ROW + COLUMN
        ds.PixelSpacing, ds.SliceThickness = SPACING, STEP
        if modality == "CT":
            ds.RescaleIntercept, ds.RescaleSlope = -1024, 1
        ds.PixelData = vol[k].tobytes()
        save(ds, os.path.join(directory, "%s%03d.dcm" % (modality.lower(), k)))


def enhanced_file(vol, path, order, frames=None, stack=None, temporal=None, positions=None, groups=True, mr=False):
    """An Enhanced CT file whose frame i is slice order[i] of `vol`; an Enhanced MR one (no rescale, pixel measures
    and plane orientation in each frame's item rather than shared) when `mr`."""
    ds = base(ENHANCED_MR if mr else ENHANCED_CT, generate_uid(), generate_uid(), "MR" if mr else "CT")
    pixel_module(ds, vol.shape[1], vol.shape[2], 16, vol.dtype == np.int16,
                 frames if frames is not None else len(order))
    if groups:
        shared = Dataset()
        measures, orientation, rescale = Dataset(), Dataset(), Dataset()
        measures.PixelSpacing, measures.SliceThickness = SPACING, STEP
        orientation.ImageOrientationPatient = ROW + COLUMN
        rescale.RescaleIntercept, rescale.RescaleSlope, rescale.RescaleType = -1024, 1, "HU"
        if not mr:
            shared.PixelMeasuresSequence = [measures]
            shared.PlaneOrientationSequence = [orientation]
            shared.PixelValueTransformationSequence = [rescale]
        ds.SharedFunctionalGroupsSequence = [shared]
        per = []
        for i, k in enumerate(order):
            item, plane, content = Dataset(), Dataset(), Dataset()
            if mr:
                item.PixelMeasuresSequence, item.PlaneOrientationSequence = [measures], [orientation]
            plane.ImagePositionPatient = positions[i] if positions else position(k)
            content.StackID = stack[i] if stack else "1"
            content.InStackPositionNumber = k + 1
            content.TemporalPositionIndex = temporal[i] if temporal else 1
            item.PlanePositionSequence, item.FrameContentSequence = [plane], [content]
            per.append(item)
        ds.PerFrameFunctionalGroupsSequence = per
    ds.PixelData = np.stack([vol[k] for k in order]).tobytes()
    save(ds, path)


def case_enhanced(out):
    vol = volume(6, 5, 7)
    write_slices(vol, os.path.join(out, "slices"), generate_uid(), generate_uid())
    order = list(range(6))
    random.Random(7).shuffle(order)
    enhanced_file(vol, os.path.join(out, "enhanced.dcm"), order)
    mr = (vol.astype(np.int32) + 3000).astype(np.uint16)
    write_slices(mr, os.path.join(out, "mr"), generate_uid(), generate_uid(), modality="MR")
    enhanced_file(mr, os.path.join(out, "enhanced_mr.dcm"), order[::-1], mr=True)
    bad = os.path.join(out, "bad")
    enhanced_file(vol, os.path.join(bad, "timeseries.dcm"), [0, 1, 2, 0, 1, 2], temporal=[1, 1, 1, 2, 2, 2])
    enhanced_file(vol, os.path.join(bad, "stacks.dcm"), [0, 1, 2, 3, 4, 5], stack=["1", "1", "1", "2", "2", "2"])
    enhanced_file(vol, os.path.join(bad, "gap.dcm"), [0, 1, 2, 4, 5])
    enhanced_file(vol, os.path.join(bad, "duplicate.dcm"), [0, 1, 2, 3, 4, 5],
                  positions=[position(k) for k in [0, 1, 2, 2, 3, 4]])
    enhanced_file(vol, os.path.join(bad, "nogroups.dcm"), order, groups=False)
    # NumberOfFrames and the per-frame items say 7 frames; the pixel data holds 6.
    enhanced_file(vol, os.path.join(bad, "shortpixels.dcm"), order + [0], frames=7)
    ds = pydicom.dcmread(os.path.join(bad, "shortpixels.dcm"))
    ds.PixelData = np.stack([vol[k] for k in order]).tobytes()
    save(ds, os.path.join(bad, "shortpixels.dcm"))
    # NumberOfFrames far beyond the per-frame items, and beyond any count.
    for name, frames in [("manyframes.dcm", 1000000), ("hugeframes.dcm", "999999999999")]:
        ds = pydicom.dcmread(os.path.join(out, "enhanced.dcm"))
        ds.NumberOfFrames = frames
        save(ds, os.path.join(bad, name))


def dose_expectation(path, name, out):
    """What the reader must deliver for an RT dose file: pixel_array * DoseGridScaling, frames sorted along the
    normal; the origin (first sorted frame's position) in RAS."""
    ds = pydicom.dcmread(path)
    frames = int(ds.get("NumberOfFrames", 1))
    values = ds.pixel_array.reshape(frames, ds.Rows, ds.Columns).astype(np.float64) * float(ds.DoseGridScaling)
    row, column = np.array(ds.ImageOrientationPatient[:3], float), np.array(ds.ImageOrientationPatient[3:], float)
    normal = np.cross(row, column)
    ipp = np.array(ds.ImagePositionPatient, float)
    offsets = np.array(ds.GridFrameOffsetVector, float)[:frames]
    along = offsets if offsets[0] == 0 else offsets - ipp.dot(normal)  # relative, or absolute coordinates
    order = np.argsort(along, kind="stable")
    origin = ipp + along[order[0]] * normal
    steps = np.diff(along[order])
    values[order].astype("<f8").tofile(os.path.join(out, name + ".f64"))
    meta = {"dims": [int(ds.Columns), int(ds.Rows), frames],
            "spacing": [float(ds.PixelSpacing[1]), float(ds.PixelSpacing[0]), float(steps[0]) if frames > 1 else 1.0],
            "origin": [-origin[0], -origin[1], origin[2]]}
    with open(os.path.join(out, name + ".json"), "w") as f:
        json.dump(meta, f)


def dose_file(path, bits, offsets, scaling, ipp):
    ds = base(RT_DOSE, generate_uid(), generate_uid(), "RTDOSE")
    frames, rows, columns = len(offsets), 4, 5
    pixel_module(ds, rows, columns, bits, False, frames)
    ds.ImagePositionPatient, ds.ImageOrientationPatient = ipp, [1, 0, 0, 0, 1, 0]
    ds.PixelSpacing, ds.SliceThickness = [2.0, 3.0], ""
    ds.FrameIncrementPointer = 0x3004000C
    ds.GridFrameOffsetVector = offsets
    ds.DoseGridScaling, ds.DoseUnits, ds.DoseType, ds.DoseSummationType = scaling, "GY", "PHYSICAL", "PLAN"
    rng = np.random.default_rng(bits)
    top = 2**bits - 1
    data = rng.integers(0, top, size=(frames, rows, columns), dtype=np.uint64)
    data[0, 0, 0] = top  # the largest stored value
    ds.PixelData = data.astype(np.uint32 if bits == 32 else np.uint16).tobytes()
    save(ds, path)


def case_dose(out):
    os.makedirs(out, exist_ok=True)
    dose_file(os.path.join(out, "dose32.dcm"), 32, [0, 3, 6, 9], 2.5e-9, [-20.0, 10.0, 5.0])
    dose_expectation(os.path.join(out, "dose32.dcm"), "dose32", out)
    dose_file(os.path.join(out, "dose16.dcm"), 16, [14.0, 11.0, 8.0, 5.0, 2.0], 1.5e-4, [-20.0, 10.0, 14.0])
    dose_expectation(os.path.join(out, "dose16.dcm"), "dose16", out)
    os.makedirs(os.path.join(out, "real"), exist_ok=True)
    shutil.copy(os.path.join(TEST_FILES, "rtdose.dcm"), os.path.join(out, "real", "rtdose.dcm"))
    dose_expectation(os.path.join(out, "real", "rtdose.dcm"), "rtdose", out)
    print(os.path.join(out, "real", "rtdose.dcm"))
    # A dose grid whose GridFrameOffsetVector holds fewer offsets than frames.
    dose_file(os.path.join(out, "bad", "offsets.dcm"), 16, [0, 3, 6], 1e-3, [0.0, 0.0, 0.0])
    ds = pydicom.dcmread(os.path.join(out, "bad", "offsets.dcm"))
    ds.GridFrameOffsetVector = [0, 3]
    save(ds, os.path.join(out, "bad", "offsets.dcm"))
    # A one-frame dose grid whose GridFrameOffsetVector is only a space: no offset at all.
    dose_file(os.path.join(out, "bad", "blankoffsets.dcm"), 16, [0], 1e-3, [0.0, 0.0, 0.0])
    ds = pydicom.dcmread(os.path.join(out, "bad", "blankoffsets.dcm"))
    ds.GridFrameOffsetVector = " "
    save(ds, os.path.join(out, "bad", "blankoffsets.dcm"))


def presentation_state(series_uid, study_uid):
    ds = base(GSPS, series_uid, study_uid, "PR")
    ds.ContentLabel, ds.ContentDescription, ds.PresentationCreationDate = "PS", "", "20261128"
    ds.PresentationCreationTime, ds.ContentCreatorName = "120000", ""
    return ds


def case_study(out):
    study = generate_uid()
    ct_series = "1.2.826.0.1.3680043.8.498.7001"
    vol = volume(5, 16, 16)
    write_slices(vol, out, ct_series, study)
    for name in ["MR_small.dcm", "rtplan.dcm", "rtstruct.dcm", "test-SR.dcm", "reportsi.dcm", "waveform_ecg.dcm"]:
        shutil.copy(os.path.join(TEST_FILES, name), os.path.join(out, name))
        print(os.path.join(out, name))
    save(presentation_state(generate_uid(), study), os.path.join(out, "gsps.dcm"))
    # The same files as a medium: pydicom's FileSet names them and writes the DICOMDIR.
    from pydicom.fileset import FileSet
    fs = FileSet()
    for name in sorted(os.listdir(out)):
        if name.startswith("ct") or name == "MR_small.dcm":
            fs.add(os.path.join(out, name))
    fs.write(os.path.join(out, "medium"))
    print(os.path.join(out, "medium", "DICOMDIR"))


def case_nometa(out):
    os.makedirs(out, exist_ok=True)
    src = os.path.join(TEST_FILES, "CT_small.dcm")
    shutil.copy(src, os.path.join(out, "ct_small.dcm"))
    ds = pydicom.dcmread(src)
    bare = copy.deepcopy(ds)
    del bare.file_meta
    bare.preamble = None
    bare.is_implicit_VR, bare.is_little_endian = True, True
    os.makedirs(os.path.join(out, "bare"), exist_ok=True)
    pydicom.dcmwrite(os.path.join(out, "bare", "ct_small.dcm"), bare, write_like_original=True)
    headless = copy.deepcopy(ds)
    headless.preamble = None
    headless.file_meta.TransferSyntaxUID = ImplicitVRLittleEndian
    headless.is_implicit_VR, headless.is_little_endian = True, True
    os.makedirs(os.path.join(out, "nopreamble"), exist_ok=True)
    pydicom.dcmwrite(os.path.join(out, "nopreamble", "ct_small.dcm"), headless, write_like_original=True)
    os.makedirs(os.path.join(out, "damaged"), exist_ok=True)
    shutil.copy(os.path.join(TEST_FILES, "no_meta.dcm"), os.path.join(out, "damaged", "no_meta.dcm"))
    for d in ["bare", "nopreamble", "damaged"]:
        print(os.path.join(out, d))


def case_pixels(out):
    for name in ["MR_small", "MR_small_RLE", "MR_small_bigendian", "MR_small_expb", "MR_small_implicit",
                 "MR_small_jp2klossless", "MR_small_jpeg_ls_lossless"]:
        os.makedirs(os.path.join(out, name), exist_ok=True)
        shutil.copy(os.path.join(TEST_FILES, name + ".dcm"), os.path.join(out, name, name + ".dcm"))
        print(os.path.join(out, name, name + ".dcm"))
    ds = pydicom.dcmread(os.path.join(TEST_FILES, "MR_small.dcm"))
    values = ds.pixel_array.astype(np.float64) * float(ds.get("RescaleSlope", 1)) + float(ds.get("RescaleIntercept", 0))
    values.astype("<f8").tofile(os.path.join(out, "MR_small.f64"))


def save_by_uid(ds, directory):
    """Saves `ds` as DIRECTORY/SOPInstanceUID.dcm, the name a DICOMweb fetch gives it."""
    save(ds, os.path.join(directory, ds.SOPInstanceUID + ".dcm"))


def renamed_instance(path, study_uid, series_uid):
    """pydicom's test file at `path` moved into a study and series (a new SOPInstanceUID, the CT's patient)."""
    ds = pydicom.dcmread(path)
    ds.SOPInstanceUID = generate_uid()
    ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
    ds.StudyInstanceUID, ds.SeriesInstanceUID = study_uid, series_uid
    ds.PatientName, ds.PatientID = "Test^Hospital", "HOSP1"
    return ds


def ct_series(vol, directory, series_uid, study_uid):
    for k in range(vol.shape[0]):
        ds = base(CT_IMAGE, series_uid, study_uid, "CT")
        ds.InstanceNumber = k + 1
        pixel_module(ds, vol.shape[1], vol.shape[2], 16, vol.dtype == np.int16)
        ds.ImagePositionPatient, ds.ImageOrientationPatient = position(k), ROW + COLUMN
        ds.PixelSpacing, ds.SliceThickness = SPACING, STEP
        ds.RescaleIntercept, ds.RescaleSlope = -1024, 1
        ds.SeriesDescription = "CT " + series_uid[-4:]
        ds.PixelData = vol[k].tobytes()
        save_by_uid(ds, directory)


def case_pacs(out):
    uids = {}
    study, series = generate_uid(), generate_uid()
    ct_series(volume(5, 16, 16), os.path.join(out, "ct"), series, study)
    for name in ["rtplan.dcm", "test-SR.dcm"]:  # non-images filed in the image series
        save_by_uid(renamed_instance(os.path.join(TEST_FILES, name), study, series), os.path.join(out, "ct"))
    plan_series, report_series = generate_uid(), generate_uid()
    save_by_uid(renamed_instance(os.path.join(TEST_FILES, "rtplan.dcm"), study, plan_series),
                os.path.join(out, "plan"))
    save_by_uid(renamed_instance(os.path.join(TEST_FILES, "test-SR.dcm"), study, report_series),
                os.path.join(out, "report"))
    uids["ct"] = {"study": study, "series": series, "plan": plan_series, "report": report_series}

    vol = volume(6, 5, 7)
    order = list(range(6))
    random.Random(7).shuffle(order)
    enhanced_file(vol, os.path.join(out, "enhanced.tmp"), order)
    ds = pydicom.dcmread(os.path.join(out, "enhanced.tmp"))
    os.remove(os.path.join(out, "enhanced.tmp"))
    ds.PatientName, ds.PatientID = "Test^Hospital", "HOSP1"
    save_by_uid(ds, os.path.join(out, "enhanced"))
    uids["enhanced"] = {"study": ds.StudyInstanceUID, "series": ds.SeriesInstanceUID}

    study, a, b = generate_uid(), generate_uid(), generate_uid()
    ct_series(volume(3, 8, 8), os.path.join(out, "two", "a"), a, study)
    ct_series(volume(4, 8, 8), os.path.join(out, "two", "b"), b, study)
    uids["two"] = {"study": study, "series": [a, b]}

    study, series = generate_uid(), generate_uid()
    noise = np.random.default_rng(5).integers(0, 4096, size=(2, 2048, 2048), dtype=np.uint16).astype(np.int16)
    ct_series(noise, os.path.join(out, "big"), series, study)
    uids["big"] = {"study": study, "series": series}

    study, series = generate_uid(), generate_uid()
    ct_series(volume(160, 8, 8), os.path.join(out, "many"), series, study)
    uids["many"] = {"study": study, "series": series}
    with open(os.path.join(out, "uids.json"), "w") as f:
        json.dump(uids, f)


if __name__ == "__main__":
    cases = {"study": case_study, "enhanced": case_enhanced, "dose": case_dose, "nometa": case_nometa,
             "pixels": case_pixels, "pacs": case_pacs}
    if len(sys.argv) != 3 or sys.argv[1] not in cases:
        sys.exit("usage: dicom_cases.py {study|enhanced|dose|nometa|pixels|pacs} DIR")
    cases[sys.argv[1]](sys.argv[2])
