"""The demo MRI (a NIfTI-1 file) as a DICOM MR series, one file a slice, for scripts/orthanc_demo.sh to upload to a
local PACS: the voxels as they are (8 or 16 bits, unsigned), the patient frame from the file's sform (else its
pixdim), converted from NIfTI's RAS to DICOM's LPS. Or a synthetic CT of N slices of 512x512 signed 16-bit voxels
(an elliptic trunk of soft tissue with lungs, a spine and ribs, in air, with noise; the same for the same N), a
series the size of a clinical CT for benchmarks. Run with Debian's /usr/bin/python3 (pydicom, numpy).

  demo_series.py INPUT.nii[.gz] DIR      writes DIR/IM0001.dcm ... and prints the StudyInstanceUID and SeriesInstanceUID
  demo_series.py --ct N DIR              the same for the synthetic CT (0.7 x 0.7 x 0.625 mm voxels)
"""
import gzip
import os
import struct
import sys

import numpy as np
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4"
CT_IMAGE = "1.2.840.10008.5.1.4.1.1.2"


def read_nifti(path):
    data = (gzip.open if path.endswith(".gz") else open)(path, "rb").read()
    if struct.unpack("<i", data[0:4])[0] != 348:
        sys.exit("%s: not a little-endian NIfTI-1 file" % path)
    dim = struct.unpack("<8h", data[40:56])
    datatype = struct.unpack("<h", data[70:72])[0]
    pixdim = struct.unpack("<8f", data[76:108])
    offset = int(struct.unpack("<f", data[108:112])[0])
    sform_code = struct.unpack("<h", data[254:256])[0]
    types = {2: np.uint8, 512: np.uint16}
    if dim[0] != 3 or datatype not in types:
        sys.exit("%s: needs a 3D volume of uint8 or uint16 voxels" % path)
    nx, ny, nz = dim[1:4]
    volume = np.frombuffer(data, types[datatype], nx * ny * nz, offset).reshape(nz, ny, nx)
    if sform_code > 0:
        affine = np.array([struct.unpack("<4f", data[280 + 16 * r:296 + 16 * r]) for r in range(3)], float)
    else:
        affine = np.array([[pixdim[1], 0, 0, 0], [0, pixdim[2], 0, 0], [0, 0, pixdim[3], 0]], float)
    return volume, affine


def synthetic_ct(n):
    """N slices of 512x512 Hounsfield units + 1024 (int16): an elliptic trunk whose outline, lungs and ribs change
    along the slices, so that no two slices are alike; noise from a fixed seed."""
    y, x = np.mgrid[0:512, 0:512].astype(np.float32) - 255.5
    random = np.random.default_rng(512)
    for k in range(n):
        t = k / max(1, n - 1)
        hu = np.full((512, 512), -1000.0, np.float32)
        a, b = 200 + 20 * np.sin(np.pi * t), 140 + 10 * np.cos(2 * np.pi * t)
        trunk = (x / a) ** 2 + (y / b) ** 2 <= 1
        hu[trunk] = 40
        hu[trunk & ((x / a) ** 2 + (y / b) ** 2 > 0.9)] = -100  # fat under the skin
        lung = 60 * np.sin(np.pi * min(1.0, 1.4 * t)) + 5
        for side in (-1, 1):
            hu[((x - side * 85) / (lung + 20)) ** 2 + ((y + 10) / (lung + 50)) ** 2 <= 1] = -850
        hu[(x ** 2 + (y - 100) ** 2) <= 22 ** 2] = 700  # the spine
        hu[(x ** 2 + (y - 100) ** 2) <= 10 ** 2] = 30   # its canal
        if (k // 12) % 2 == 0:  # ribs every other 12 slices
            ring = (x / (a - 18)) ** 2 + (y / (b - 14)) ** 2
            hu[(ring > 0.92) & (ring <= 1) & (y > -60)] = 600
        hu += random.normal(0, 12, hu.shape).astype(np.float32)
        yield np.clip(hu + 1024, -2000, 4000).astype(np.int16)


def write_series(slices, count, out, sop_class, modality, patient, description, spacing, row, column, origin, normal,
                 signed=False, intercept=None):
    """Writes each slice as DIR/IMkkkk.dcm of one new series; returns its study and series UIDs."""
    os.makedirs(out, exist_ok=True)
    study, series = generate_uid(), generate_uid()
    for k, pixels in enumerate(slices):
        bits = pixels.dtype.itemsize * 8
        ds = Dataset()
        ds.file_meta = FileMetaDataset()
        ds.file_meta.MediaStorageSOPClassUID = sop_class
        ds.SOPInstanceUID = generate_uid()
        ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
        ds.file_meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds.is_little_endian, ds.is_implicit_VR = True, False
        ds.SOPClassUID, ds.Modality = sop_class, modality
        ds.StudyInstanceUID, ds.SeriesInstanceUID = study, series
        ds.PatientName, ds.PatientID, ds.PatientBirthDate, ds.PatientSex = patient, "DEMO1", "", ""
        ds.StudyDate, ds.StudyTime, ds.StudyID, ds.AccessionNumber = "20261204", "120000", "1", ""
        ds.ReferringPhysicianName, ds.SeriesNumber, ds.InstanceNumber = "", 1, k + 1
        ds.SeriesDescription = description
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.Rows, ds.Columns = pixels.shape
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = bits, bits, bits - 1, int(signed)
        ds.PixelSpacing = [spacing[1], spacing[0]]  # between rows (along j), between columns (along i)
        ds.SliceThickness = spacing[2]
        if intercept is not None:
            ds.RescaleIntercept, ds.RescaleSlope = intercept, 1
        ds.ImageOrientationPatient = [float(v) for v in np.concatenate([row, column])]
        ds.ImagePositionPatient = [float(v) for v in origin + k * normal]
        ds.PixelData = np.ascontiguousarray(pixels).tobytes()
        ds.save_as(os.path.join(out, "IM%04d.dcm" % (k + 1)), write_like_original=False)
    if k + 1 != count:
        sys.exit("demo_series.py: wrote %d slices, not %d" % (k + 1, count))
    return study, series


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--ct" and sys.argv[2].isdigit() and int(sys.argv[2]) > 0:
        n, spacing = int(sys.argv[2]), [0.7, 0.7, 0.625]
        study, series = write_series(synthetic_ct(n), n, sys.argv[3], CT_IMAGE, "CT", "Demo^Trunk",
                                     "synthetic CT (%d slices)" % n,
                                     spacing, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                                     np.array([-179.0, -179.0, 0.0]), np.array([0, 0, -spacing[2]]), signed=True,
                                     intercept=-1024)
        print(study, series)
        return
    if len(sys.argv) != 3:
        sys.exit("usage: demo_series.py INPUT.nii[.gz] DIR | demo_series.py --ct N DIR")
    volume, affine = read_nifti(sys.argv[1])
    lps = np.array([-1.0, -1.0, 1.0])
    axes = [affine[:, i] * lps for i in range(3)]
    spacing = [float(np.linalg.norm(a)) for a in axes]
    study, series = write_series(volume, volume.shape[0], sys.argv[2], MR_IMAGE, "MR", "Demo^Brain",
                                 "demo MRI (" + os.path.basename(sys.argv[1]) + ")", spacing, axes[0] / spacing[0],
                                 axes[1] / spacing[1], affine[:, 3] * lps, axes[2])
    print(study, series)


if __name__ == "__main__":
    main()
