"""The demo MRI (a NIfTI-1 file) as a DICOM MR series, one file a slice, for scripts/orthanc_demo.sh to upload to a
local PACS: the voxels as they are (8 or 16 bits, unsigned), the patient frame from the file's sform (else its
pixdim), converted from NIfTI's RAS to DICOM's LPS. Run with Debian's /usr/bin/python3 (pydicom, numpy).

  demo_series.py INPUT.nii[.gz] DIR      writes DIR/IM0001.dcm ... and prints the StudyInstanceUID and SeriesInstanceUID
"""
import gzip
import os
import struct
import sys

import numpy as np
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4"


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


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: demo_series.py INPUT.nii[.gz] DIR")
    volume, affine = read_nifti(sys.argv[1])
    out = sys.argv[2]
    os.makedirs(out, exist_ok=True)
    lps = np.array([-1.0, -1.0, 1.0])
    axes = [affine[:, i] * lps for i in range(3)]
    spacing = [float(np.linalg.norm(a)) for a in axes]
    row, column = axes[0] / spacing[0], axes[1] / spacing[1]
    study, series = generate_uid(), generate_uid()
    bits = volume.dtype.itemsize * 8
    for k in range(volume.shape[0]):
        ds = Dataset()
        ds.file_meta = FileMetaDataset()
        ds.file_meta.MediaStorageSOPClassUID = MR_IMAGE
        ds.SOPInstanceUID = generate_uid()
        ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
        ds.file_meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds.is_little_endian, ds.is_implicit_VR = True, False
        ds.SOPClassUID, ds.Modality = MR_IMAGE, "MR"
        ds.StudyInstanceUID, ds.SeriesInstanceUID = study, series
        ds.PatientName, ds.PatientID, ds.PatientBirthDate, ds.PatientSex = "Demo^Brain", "DEMO1", "", ""
        ds.StudyDate, ds.StudyTime, ds.StudyID, ds.AccessionNumber = "20261204", "120000", "1", ""
        ds.ReferringPhysicianName, ds.SeriesNumber, ds.InstanceNumber = "", 1, k + 1
        ds.SeriesDescription = "demo MRI (" + os.path.basename(sys.argv[1]) + ")"
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.Rows, ds.Columns = volume.shape[1], volume.shape[2]
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = bits, bits, bits - 1, 0
        ds.PixelSpacing = [spacing[1], spacing[0]]  # between rows (along j), between columns (along i)
        ds.SliceThickness = spacing[2]
        ds.ImageOrientationPatient = [float(v) for v in np.concatenate([row, column])]
        ds.ImagePositionPatient = [float(v) for v in affine[:, 3] * lps + k * axes[2]]
        ds.PixelData = np.ascontiguousarray(volume[k]).tobytes()
        ds.save_as(os.path.join(out, "IM%04d.dcm" % (k + 1)), write_like_original=False)
    print(study, series)


if __name__ == "__main__":
    main()
