// ffseg tools: DICOM Segmentation out through DCMTK (dicom_seg.h).
#include "dicom_seg.h"

#include <memory>

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmfg/fgderimg.h>
#include <dcmtk/dcmfg/fgfracon.h>
#include <dcmtk/dcmfg/fgpixmsr.h>
#include <dcmtk/dcmfg/fgplanor.h>
#include <dcmtk/dcmfg/fgplanpo.h>
#include <dcmtk/dcmiod/cielabutil.h>
#include <dcmtk/dcmiod/iodreferences.h>
#include <dcmtk/dcmseg/segdoc.h>
#include <dcmtk/dcmseg/segment.h>

#include "dicom_planes.h"
#include "dicom_study.h"
#include "dicom_write.h"

namespace ffseg_tools {

namespace {

bool set_patient_study(DcmSegmentation& seg, const DicomSource& src, DcmtkCheck& ck) {
    if (!src.generated()) {
        ck(seg.importFromSourceImage(src.files[0].c_str()), "importing the source series' patient and study");
        return ck(seg.getFrameOfReference().setFrameOfReferenceUID(src.frame_of_reference_uid.c_str()),
                  "FrameOfReferenceUID");
    }
    ck(seg.getPatient().setPatientName(kGeneratedPatientName), "PatientName");
    ck(seg.getPatient().setPatientID(kGeneratedPatientId), "PatientID");
    ck(seg.getStudy().setStudyInstanceUID(src.study_uid.c_str()), "StudyInstanceUID");
    ck(seg.getStudy().setStudyDate(dicom_now("%Y%m%d").c_str()), "StudyDate");
    ck(seg.getStudy().setStudyTime(dicom_now("%H%M%S").c_str()), "StudyTime");
    ck(seg.getStudy().setStudyID("1"), "StudyID");
    return ck(seg.getFrameOfReference().setFrameOfReferenceUID(src.frame_of_reference_uid.c_str()), "FrameOfReferenceUID");
}

bool add_segment(DcmSegmentation& seg, const DicomSegment& s, Uint16* number, DcmtkCheck& ck) {
    DcmSegment* d = nullptr;
    // The object is an anatomical structure the user pointed at; which one
    // ffseg does not know, so the type stays the general "Organ".
    const CodeSequenceMacro category("91723000", "SCT", "Anatomical Structure");
    const CodeSequenceMacro type("113343008", "SCT", "Organ");
    if (!ck(DcmSegment::create(d, s.name.c_str(), category, type, DcmSegTypes::SAT_SEMIAUTOMATIC, "ffseg"),
            "creating a segment"))
        return false;
    std::unique_ptr<DcmSegment> owned(d);
    ck(d->setSegmentDescription(("label " + std::to_string(s.label)).c_str()), "SegmentDescription");
    double L, a, b;
    IODCIELabUtil::rgb2DicomLab(L, a, b, s.rgb[0] / 255.0, s.rgb[1] / 255.0, s.rgb[2] / 255.0);
    ck(d->setRecommendedDisplayCIELabValue(Uint16(L + 0.5), Uint16(a + 0.5), Uint16(b + 0.5)), "RecommendedDisplayCIELabValue");
    if (!ck(seg.addSegment(d, *number), "adding a segment")) return false;
    owned.release();  // the segmentation owns it now
    return true;
}

bool write_seg(const std::string& path, const NiftiImage& grid, const std::vector<DicomSegment>& segments,
               const DicomSource& src, std::string* err) {
    DicomPlanes planes;
    if (!dicom_planes(grid, &planes, err)) return false;
    if (!src.generated() && src.sop_instance_uids.size() != size_t(grid.dims[2])) {
        *err = "the source series has " + std::to_string(src.sop_instance_uids.size()) + " slices, the grid " +
               std::to_string(grid.dims[2]);
        return false;
    }
    if (segments.empty()) {
        *err = "no segment";
        return false;
    }
    DcmtkCheck ck{err};
    IODGeneralEquipmentModule::EquipmentInfo equipment("ffseg", "ffseg", "1", "ffseg " FFSEG_TOOLS_VERSION);
    ContentIdentificationMacro content("1", "FFSEG", "ffseg deformable-mesh segmentation", "ffseg^");
    DcmSegmentation* raw = nullptr;
    if (!ck(DcmSegmentation::createBinarySegmentation(raw, Uint16(grid.dims[1]), Uint16(grid.dims[0]), equipment, content),
            "creating the segmentation"))
        return false;
    std::unique_ptr<DcmSegmentation> seg(raw);
    if (!set_patient_study(*seg, src, ck)) return false;
    ck(seg->getSeries().setSeriesNumber("300"), "SeriesNumber");
    ck(seg->getSeries().setSeriesDescription(src.generated() ? "ffseg segmentation (no source images)"
                                                             : "ffseg segmentation"), "SeriesDescription");
    if (src.generated()) ck(seg->getGeneralImage().setImageComments(src.note.c_str()), "ImageComments");

    FGPixelMeasures measures;
    const double spacing[2] = {planes.row_spacing, planes.col_spacing};
    ck(measures.setPixelSpacing(dicom_ds_list(spacing, 2).c_str()), "PixelSpacing");
    ck(measures.setSliceThickness(dicom_ds(planes.slice_thickness).c_str()), "SliceThickness");
    FGPlaneOrientationPatient orientation;
    const double* r = planes.row_dir;
    const double* c = planes.col_dir;
    ck(orientation.setImageOrientationPatient(dicom_ds(r[0]).c_str(), dicom_ds(r[1]).c_str(), dicom_ds(r[2]).c_str(),
                                              dicom_ds(c[0]).c_str(), dicom_ds(c[1]).c_str(), dicom_ds(c[2]).c_str()),
       "ImageOrientationPatient");
    ck(seg->addForAllFrames(measures), "shared PixelMeasures");
    ck(seg->addForAllFrames(orientation), "shared PlaneOrientation");
    const std::string dim_uid = dicom_new_uid();
    IODMultiframeDimensionModule& dims = seg->getDimensions();
    ck(dims.addDimensionIndex(DCM_ReferencedSegmentNumber, dim_uid.c_str(), DCM_SegmentIdentificationSequence,
                              "ReferencedSegmentNumber"), "the segment dimension");
    ck(dims.addDimensionIndex(DCM_ImagePositionPatient, dim_uid.c_str(), DCM_PlanePositionSequence,
                              "ImagePositionPatient"), "the position dimension");
    if (!ck.ok) return false;

    const size_t per = size_t(grid.dims[0]) * size_t(grid.dims[1]);
    std::vector<Uint8> frame(per);
    // The frames' bits, one after the other with no padding between frames
    // (PS3.5 8.1.1): DCMTK 3.6.7 (Debian 12) shifts every frame after the
    // first whose bit count is not a multiple of 8 by up to a byte, so its
    // Pixel Data is replaced by this.
    std::vector<Uint8> packed;
    size_t bit = 0;
    for (const DicomSegment& s : segments) {
        Uint16 number = 0;
        if (!add_segment(*seg, s, &number, ck)) return false;
        std::vector<int> slices;
        for (int k = 0; k < grid.dims[2]; ++k)
            for (size_t q = 0; q < per; ++q)
                if (s.mask[size_t(k) * per + q]) {
                    slices.push_back(k);
                    break;
                }
        // A segment must have a frame: an empty one in the middle slice.
        const bool empty = slices.empty();
        if (empty) slices.push_back(grid.dims[2] / 2);
        for (int k : slices) {
            packed.resize((bit + per + 7) / 8, 0);
            for (size_t q = 0; q < per; ++q, ++bit) {
                frame[q] = !empty && s.mask[size_t(k) * per + q] ? 1 : 0;
                if (frame[q]) packed[bit >> 3] |= Uint8(1u << (bit & 7));
            }
            FGPlanePosPatient position;
            const std::array<double, 3>& p = planes.positions[size_t(k)];
            ck(position.setImagePositionPatient(dicom_ds(p[0]).c_str(), dicom_ds(p[1]).c_str(), dicom_ds(p[2]).c_str()),
               "ImagePositionPatient");
            FGFrameContent content_fg;
            ck(content_fg.setDimensionIndexValues(number, 0), "DimensionIndexValues");
            ck(content_fg.setDimensionIndexValues(Uint32(k + 1), 1), "DimensionIndexValues");
            OFVector<FGBase*> groups;
            groups.push_back(&position);
            groups.push_back(&content_fg);
            FGDerivationImage derivation;
            if (!src.generated()) {
                DerivationImageItem* item = nullptr;
                ck(derivation.addDerivationImageItem(CodeSequenceMacro("113076", "DCM", "Segmentation"), "", item),
                   "DerivationImageSequence");
                if (item) {
                    SourceImageItem* source_item = new SourceImageItem();
                    source_item->getPurposeOfReferenceCode().set("121322", "DCM",
                                                                 "Source image for image processing operation");
                    source_item->getImageSOPInstanceReference().setReferencedSOPClassUID(src.sop_class_uid.c_str());
                    source_item->getImageSOPInstanceReference().setReferencedSOPInstanceUID(
                        src.sop_instance_uids[size_t(k)].c_str());
                    item->getSourceImageItems().push_back(source_item);
                }
                groups.push_back(&derivation);
            }
            if (!ck(seg->addFrame(frame.data(), number, groups), "adding a frame")) return false;
        }
    }
    if (!src.generated()) {
        // The Common Instance Reference module: every slice of the source series.
        OFString patient_id;
        seg->getPatient().getPatientID(patient_id);
        IODReferences refs;
        for (const std::string& uid : src.sop_instance_uids)
            refs.add(new IODImageReference(patient_id, src.study_uid.c_str(), src.series_uid.c_str(), uid.c_str(),
                                           src.sop_class_uid.c_str()));
        if (seg->getCommonInstanceReference().addReferences(refs, src.study_uid.c_str()) != src.sop_instance_uids.size()) {
            *err = "cannot reference the source series' images";
            return false;
        }
    }
    DcmFileFormat file;
    if (!ck(seg->writeDataset(*file.getDataset()), "encoding the segmentation")) return false;
    if (!ck(file.getDataset()->putAndInsertUint8Array(DCM_PixelData, packed.data(), Uint32(packed.size())),
            "PixelData"))
        return false;
    return ck(file.saveFile(path.c_str(), EXS_LittleEndianExplicit), "writing the file");
}

}  // namespace

bool dicom_seg_write(const std::string& path, const NiftiImage& grid, const std::vector<DicomSegment>& segments,
                     const DicomSource& source, std::string* err) {
    return dicom_write_guarded(
        "DICOM segmentation", path, [&](std::string* e) { return write_seg(path, grid, segments, source, e); }, err);
}

}  // namespace ffseg_tools
