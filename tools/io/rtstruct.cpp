// ffseg tools: RT Structure Set out through DCMTK (rtstruct.h).
#include "rtstruct.h"

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmrt/drtstrct.h>

#include "dicom_planes.h"
#include "dicom_study.h"
#include "dicom_write.h"

namespace ffseg_tools {

namespace {

// The SOP class a structure set names for the study it references (DICOM
// PS3.3 C.8.8.5: Detached Study Management, retired but still the value
// planning systems expect).
constexpr const char* kStudyComponentClass = "1.2.840.10008.3.1.2.3.1";

bool set_patient_study(DRTStructureSetIOD& rt, const DicomSource& src, DcmtkCheck& ck) {
    if (!src.generated()) {
        DcmFileFormat file;
        if (!ck(file.loadFile(src.files[0].c_str()), "reading " + src.files[0])) return false;
        ck(rt.readPatientData(*file.getDataset()), "the source series' patient");
        return ck(rt.readStudyData(*file.getDataset()), "the source series' study");
    }
    ck(rt.setPatientName(kGeneratedPatientName), "PatientName");
    ck(rt.setPatientID(kGeneratedPatientId), "PatientID");
    ck(rt.setStudyInstanceUID(src.study_uid.c_str()), "StudyInstanceUID");
    ck(rt.setStudyDate(dicom_now("%Y%m%d").c_str()), "StudyDate");
    ck(rt.setStudyTime(dicom_now("%H%M%S").c_str()), "StudyTime");
    return ck(rt.setStudyID("1"), "StudyID");
}

bool add_references(DRTStructureSetIOD& rt, const DicomSource& src, DcmtkCheck& ck) {
    DRTReferencedFrameOfReferenceSequence::Item* f = nullptr;
    if (!ck(rt.getReferencedFrameOfReferenceSequence().addItem(f), "ReferencedFrameOfReferenceSequence")) return false;
    ck(f->setFrameOfReferenceUID(src.frame_of_reference_uid.c_str()), "FrameOfReferenceUID");
    if (src.generated()) return ck.ok;
    DRTRTReferencedStudySequence::Item* st = nullptr;
    if (!ck(f->getRTReferencedStudySequence().addItem(st), "RTReferencedStudySequence")) return false;
    ck(st->setReferencedSOPClassUID(kStudyComponentClass), "ReferencedSOPClassUID");
    ck(st->setReferencedSOPInstanceUID(src.study_uid.c_str()), "ReferencedSOPInstanceUID");
    DRTRTReferencedSeriesSequence::Item* se = nullptr;
    if (!ck(st->getRTReferencedSeriesSequence().addItem(se), "RTReferencedSeriesSequence")) return false;
    ck(se->setSeriesInstanceUID(src.series_uid.c_str()), "SeriesInstanceUID");
    for (const std::string& uid : src.sop_instance_uids) {
        DRTContourImageSequence::Item* im = nullptr;
        if (!ck(se->getContourImageSequence().addItem(im), "ContourImageSequence")) return false;
        ck(im->setReferencedSOPClassUID(src.sop_class_uid.c_str()), "ReferencedSOPClassUID");
        ck(im->setReferencedSOPInstanceUID(uid.c_str()), "ReferencedSOPInstanceUID");
    }
    return ck.ok;
}

bool add_roi(DRTStructureSetIOD& rt, const RtRoi& roi, const DicomSource& src, DcmtkCheck& ck) {
    const std::string number = std::to_string(roi.number);
    DRTStructureSetROISequence::Item* s = nullptr;
    if (!ck(rt.getStructureSetROISequence().addItem(s), "StructureSetROISequence")) return false;
    ck(s->setROINumber(number.c_str()), "ROINumber");
    ck(s->setReferencedFrameOfReferenceUID(src.frame_of_reference_uid.c_str()), "ReferencedFrameOfReferenceUID");
    ck(s->setROIName(roi.name.c_str()), "ROIName");
    ck(s->setROIGenerationAlgorithm("SEMIAUTOMATIC"), "ROIGenerationAlgorithm");
    ck(s->setROIGenerationDescription("ffseg deformable mesh cut by the slice planes"), "ROIGenerationDescription");

    DRTROIContourSequence::Item* c = nullptr;
    if (!ck(rt.getROIContourSequence().addItem(c), "ROIContourSequence")) return false;
    ck(c->setReferencedROINumber(number.c_str()), "ReferencedROINumber");
    const std::string colour = std::to_string(roi.rgb[0]) + "\\" + std::to_string(roi.rgb[1]) + "\\" + std::to_string(roi.rgb[2]);
    ck(c->setROIDisplayColor(colour.c_str()), "ROIDisplayColor");
    int n = 0;
    for (const RtContour& contour : roi.contours) {
        DRTContourSequence::Item* it = nullptr;
        if (!ck(c->getContourSequence().addItem(it), "ContourSequence")) return false;
        ck(it->setContourNumber(std::to_string(++n).c_str()), "ContourNumber");
        ck(it->setContourGeometricType("CLOSED_PLANAR"), "ContourGeometricType");
        ck(it->setNumberOfContourPoints(std::to_string(contour.lps.size() / 3).c_str()), "NumberOfContourPoints");
        ck(it->setContourData(dicom_ds_list(contour.lps.data(), contour.lps.size()).c_str(), OFFalse), "ContourData");
        if (!src.generated()) {
            DRTContourImageSequence::Item* im = nullptr;
            if (!ck(it->getContourImageSequence().addItem(im), "ContourImageSequence")) return false;
            ck(im->setReferencedSOPClassUID(src.sop_class_uid.c_str()), "ReferencedSOPClassUID");
            ck(im->setReferencedSOPInstanceUID(src.sop_instance_uids[size_t(contour.slice)].c_str()),
               "ReferencedSOPInstanceUID");
        }
    }
    DRTRTROIObservationsSequence::Item* o = nullptr;
    if (!ck(rt.getRTROIObservationsSequence().addItem(o), "RTROIObservationsSequence")) return false;
    ck(o->setObservationNumber(number.c_str()), "ObservationNumber");
    ck(o->setReferencedROINumber(number.c_str()), "ReferencedROINumber");
    ck(o->setRTROIInterpretedType("ORGAN"), "RTROIInterpretedType");
    return ck(o->setROIInterpreter(""), "ROIInterpreter");
}

bool write_rt(const std::string& path, const NiftiImage& grid, const std::vector<RtRoi>& rois, const DicomSource& src,
              std::string* err) {
    if (!src.generated() && src.sop_instance_uids.size() != size_t(grid.dims[2])) {
        *err = "the source series has " + std::to_string(src.sop_instance_uids.size()) + " slices, the grid " +
               std::to_string(grid.dims[2]);
        return false;
    }
    for (const RtRoi& roi : rois)
        for (const RtContour& c : roi.contours)
            if (c.slice < 0 || c.slice >= grid.dims[2] || c.lps.size() < 9 || c.lps.size() % 3 != 0) {
                *err = "ROI " + roi.name + ": a contour is not a polygon on a slice of the grid";
                return false;
            }
    DcmtkCheck ck{err};
    DRTStructureSetIOD rt;
    if (!set_patient_study(rt, src, ck)) return false;
    const std::string date = dicom_now("%Y%m%d"), time_of_day = dicom_now("%H%M%S");
    ck(rt.setSOPClassUID(UID_RTStructureSetStorage), "SOPClassUID");
    ck(rt.setSOPInstanceUID(dicom_new_uid().c_str()), "SOPInstanceUID");
    ck(rt.setInstanceCreationDate(date.c_str()), "InstanceCreationDate");
    ck(rt.setInstanceCreationTime(time_of_day.c_str()), "InstanceCreationTime");
    ck(rt.setModality("RTSTRUCT"), "Modality");
    ck(rt.setManufacturer("ffseg"), "Manufacturer");
    ck(rt.setSoftwareVersions("ffseg " FFSEG_TOOLS_VERSION), "SoftwareVersions");
    ck(rt.setSeriesInstanceUID(dicom_new_uid().c_str()), "SeriesInstanceUID");
    ck(rt.setSeriesNumber("301"), "SeriesNumber");
    ck(rt.setSeriesDescription(src.generated() ? "ffseg structures (no source images)" : "ffseg structures"),
       "SeriesDescription");
    ck(rt.setFrameOfReferenceUID(src.frame_of_reference_uid.c_str()), "FrameOfReferenceUID");
    ck(rt.setStructureSetLabel("ffseg"), "StructureSetLabel");
    ck(rt.setStructureSetDate(date.c_str()), "StructureSetDate");
    ck(rt.setStructureSetTime(time_of_day.c_str()), "StructureSetTime");
    if (src.generated()) ck(rt.setStructureSetDescription(src.note.substr(0, 1024).c_str()), "StructureSetDescription");
    if (!ck.ok || !add_references(rt, src, ck)) return false;
    for (const RtRoi& roi : rois)
        if (!add_roi(rt, roi, src, ck)) return false;
    DcmFileFormat file;
    if (!ck(rt.write(*file.getDataset()), "encoding the structure set")) return false;
    return ck(file.saveFile(path.c_str(), EXS_LittleEndianExplicit), "writing the file");
}

}  // namespace

bool rtstruct_write(const std::string& path, const NiftiImage& grid, const std::vector<RtRoi>& rois,
                    const DicomSource& source, std::string* err) {
    return dicom_write_guarded(
        "RT structure set", path, [&](std::string* e) { return write_rt(path, grid, rois, source, e); }, err);
}

}  // namespace ffseg_tools
