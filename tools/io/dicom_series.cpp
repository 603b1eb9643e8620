// ffseg tools: DICOM series through GDCM (see dicom_series.h).
#include "dicom_series.h"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>

#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmPixelFormat.h>
#include <gdcmStringFilter.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include "byte_io.h"
#include "image_common.h"

namespace ffseg_tools {
namespace {

using io::fail;
using io::fmt;

struct Slice {
    std::string file;
    double ipp[3], iop[6], pixel_spacing[2], slope = 1, intercept = 0;
    double position = 0;  // along the normal
    unsigned cols = 0, rows = 0;
    const img::ScalarType* type = nullptr;
    std::string series, sop_instance, sop_class, study, frame_of_reference;
    std::vector<uint8_t> pixels;  // as stored, native order
};

std::string tag_string(const gdcm::File& f, uint16_t group, uint16_t element) {
    gdcm::StringFilter sf;
    sf.SetFile(f);
    const gdcm::Tag t(group, element);
    if (!f.GetDataSet().FindDataElement(t)) return std::string();
    return img::trim(sf.ToString(t));
}

// "a\b\c" -> n finite numbers; false if absent or malformed.
bool ds_numbers(const std::string& s, int n, double* out) {
    std::vector<std::string> parts;
    size_t start = 0;
    for (;;) {
        const size_t p = s.find('\\', start);
        parts.push_back(img::trim(s.substr(start, p == std::string::npos ? std::string::npos : p - start)));
        if (p == std::string::npos) break;
        start = p + 1;
    }
    if (int(parts.size()) != n) return false;
    for (int k = 0; k < n; ++k)
        if (!img::parse_double(parts[size_t(k)], &out[k])) return false;
    return true;
}

const img::ScalarType* pixel_type(const gdcm::PixelFormat& pf) {
    switch (pf.GetScalarType()) {
        case gdcm::PixelFormat::UINT8: return img::scalar_type_by_name("uint8");
        case gdcm::PixelFormat::INT8: return img::scalar_type_by_name("int8");
        case gdcm::PixelFormat::UINT16: return img::scalar_type_by_name("uint16");
        case gdcm::PixelFormat::INT16: return img::scalar_type_by_name("int16");
        case gdcm::PixelFormat::UINT32: return img::scalar_type_by_name("uint32");
        case gdcm::PixelFormat::INT32: return img::scalar_type_by_name("int32");
        case gdcm::PixelFormat::FLOAT32: return img::scalar_type_by_name("float32");
        case gdcm::PixelFormat::FLOAT64: return img::scalar_type_by_name("float64");
        default: return nullptr;
    }
}

bool read_slice(const std::string& path, Slice* s, std::string* err) {
    gdcm::ImageReader r;
    r.SetFileName(path.c_str());
    if (!r.Read()) return fail(err, "GDCM cannot read it as a DICOM image");
    const gdcm::File& f = r.GetFile();
    const gdcm::Image& im = r.GetImage();
    const auto field = [&](const char* name, const char* tag) {
        return fail(err, std::string(name) + " " + tag + " is missing or malformed");
    };
    if (!ds_numbers(tag_string(f, 0x0020, 0x0032), 3, s->ipp)) return field("ImagePositionPatient", "(0020,0032)");
    if (!ds_numbers(tag_string(f, 0x0020, 0x0037), 6, s->iop)) return field("ImageOrientationPatient", "(0020,0037)");
    if (!ds_numbers(tag_string(f, 0x0028, 0x0030), 2, s->pixel_spacing) || !(s->pixel_spacing[0] > 0) ||
        !(s->pixel_spacing[1] > 0))
        return field("PixelSpacing", "(0028,0030)");
    const std::string slope = tag_string(f, 0x0028, 0x1053), icpt = tag_string(f, 0x0028, 0x1052);
    if (!slope.empty() && (!ds_numbers(slope, 1, &s->slope) || s->slope == 0)) return field("RescaleSlope", "(0028,1053)");
    if (!icpt.empty() && !ds_numbers(icpt, 1, &s->intercept)) return field("RescaleIntercept", "(0028,1052)");
    s->series = tag_string(f, 0x0020, 0x000e);
    s->sop_class = tag_string(f, 0x0008, 0x0016);
    s->sop_instance = tag_string(f, 0x0008, 0x0018);
    s->study = tag_string(f, 0x0020, 0x000d);
    s->frame_of_reference = tag_string(f, 0x0020, 0x0052);
    if (im.GetNumberOfDimensions() == 3 && im.GetDimensions()[2] > 1)
        return fail(err, fmt("a multi-frame image (%u frames): only one frame per file is supported",
                             im.GetDimensions()[2]));
    s->cols = im.GetDimensions()[0];
    s->rows = im.GetDimensions()[1];
    const gdcm::PixelFormat& pf = im.GetPixelFormat();
    if (pf.GetSamplesPerPixel() != 1)
        return fail(err, fmt("SamplesPerPixel (0028,0002) is %u: only grey-level images are supported",
                             unsigned(pf.GetSamplesPerPixel())));
    s->type = pixel_type(pf);
    if (!s->type) return fail(err, std::string("unsupported pixel type ") + pf.GetScalarTypeAsString());
    const size_t need = size_t(s->cols) * s->rows * size_t(s->type->file_bytes);
    if (im.GetBufferLength() != need)
        return fail(err, fmt("pixel data of %lu bytes, %zu expected", im.GetBufferLength(), need));
    s->pixels.resize(need);
    if (!im.GetBuffer(reinterpret_cast<char*>(s->pixels.data()))) return fail(err, "GDCM cannot decode the pixel data");
    return true;
}

template <class T>
void rescale_into(const uint8_t* in, size_t n, double slope, double icpt, double* out) {
    for (size_t i = 0; i < n; ++i) {
        T v;
        std::memcpy(&v, in + i * sizeof(T), sizeof v);
        out[i] = slope * double(v) + icpt;
    }
}

// The identifiers a written object refers to, slice by slice.
bool take_source(const std::vector<Slice>& s, DicomSource* src, std::string* err) {
    for (const Slice& x : s) {
        const auto missing = [&](const char* what) { return fail(err, x.file + ": " + what + " is missing (needed to refer to the series)"); };
        if (x.sop_instance.empty()) return missing("SOPInstanceUID (0008,0018)");
        if (x.study.empty()) return missing("StudyInstanceUID (0020,000D)");
        if (x.study != s[0].study || x.frame_of_reference != s[0].frame_of_reference || x.sop_class != s[0].sop_class)
            return fail(err, x.file + ": StudyInstanceUID, FrameOfReferenceUID or SOPClassUID differs from " + s[0].file + "'s");
        src->files.push_back(x.file);
        src->sop_instance_uids.push_back(x.sop_instance);
    }
    src->sop_class_uid = s[0].sop_class;
    src->study_uid = s[0].study;
    src->series_uid = s[0].series;
    src->frame_of_reference_uid = s[0].frame_of_reference;
    return true;
}

bool read_series(const std::string& dir, NiftiImage* out, std::string* err, const NiftiLimits& lim, DicomSource* src) {
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetError(false);
    std::vector<std::string> files;
    if (DIR* d = ::opendir(dir.c_str())) {
        while (const dirent* e = ::readdir(d)) {
            const std::string n = e->d_name;
            if (n.empty() || n[0] == '.' || n == "DICOMDIR") continue;
            struct stat st;
            const std::string p = dir + "/" + n;
            if (::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode)) files.push_back(p);
        }
        ::closedir(d);
    } else {
        return fail(err, fmt("cannot list the directory: %s", std::strerror(errno)));
    }
    if (files.empty()) return fail(err, "the directory holds no file (a DICOM series is one file per slice)");
    std::sort(files.begin(), files.end());
    std::vector<Slice> s(files.size());
    uint64_t total = 0;
    for (size_t k = 0; k < files.size(); ++k) {
        s[k].file = files[k];
        if (!read_slice(files[k], &s[k], err)) return fail(err, files[k] + ": " + *err);
        total += s[k].pixels.size();
        if (total > lim.max_bytes) return fail(err, "the series exceeds the reader's bound of " + std::to_string(lim.max_bytes) + " bytes");
        const Slice& a = s[0];
        const Slice& b = s[k];
        const auto differs = [&](const char* what) {
            return fail(err, files[k] + ": " + what + " differs from " + files[0] + "'s (one series, one geometry)");
        };
        if (b.series != a.series) return differs("SeriesInstanceUID (0020,000E)");
        if (b.cols != a.cols || b.rows != a.rows) return differs("Rows / Columns");
        if (b.type != a.type) return differs("the pixel type");
        for (int q = 0; q < 6; ++q)
            if (std::fabs(b.iop[q] - a.iop[q]) > 1e-4) return differs("ImageOrientationPatient (0020,0037)");
        for (int q = 0; q < 2; ++q)
            if (std::fabs(b.pixel_spacing[q] - a.pixel_spacing[q]) > 1e-6 * a.pixel_spacing[q]) return differs("PixelSpacing (0028,0030)");
    }
    const double* iop = s[0].iop;
    double normal[3] = {iop[1] * iop[5] - iop[2] * iop[4], iop[2] * iop[3] - iop[0] * iop[5], iop[0] * iop[4] - iop[1] * iop[3]};
    const double nn = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    if (!(nn > 0.5)) return fail(err, "ImageOrientationPatient (0020,0037): the row and column directions are not orthogonal unit vectors");
    for (double& c : normal) c /= nn;
    for (Slice& x : s) x.position = x.ipp[0] * normal[0] + x.ipp[1] * normal[1] + x.ipp[2] * normal[2];
    std::stable_sort(s.begin(), s.end(), [](const Slice& a, const Slice& b) { return a.position < b.position; });
    const size_t n = s.size();
    double step[3] = {normal[0], normal[1], normal[2]};  // one slice: 1 mm along the normal
    if (n > 1)
        for (int c = 0; c < 3; ++c) step[c] = (s[n - 1].ipp[c] - s[0].ipp[c]) / double(n - 1);
    const double gap = std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
    for (size_t k = 1; k < n; ++k) {
        if (std::fabs(s[k].position - s[k - 1].position) < 1e-3)
            return fail(err, "two slices at the same position: " + s[k - 1].file + " and " + s[k].file);
        double dev = 0;
        for (int c = 0; c < 3; ++c) dev = std::max(dev, std::fabs(s[k].ipp[c] - (s[0].ipp[c] + double(k) * step[c])));
        if (dev > 0.01)
            return fail(err, fmt("ImagePositionPatient (0020,0032): the slices are not evenly spaced (%s is %.4g mm off "
                                 "the mean step of %.6g mm: a missing slice?)",
                                 s[k].file.c_str(), dev, gap));
    }
    const int dims[3] = {int(s[0].cols), int(s[0].rows), int(n)};
    bool same_rescale = true;
    for (const Slice& x : s) same_rescale = same_rescale && x.slope == s[0].slope && x.intercept == s[0].intercept;
    const img::ScalarType& t = *s[0].type;
    std::vector<uint8_t> all;
    all.reserve(size_t(total));
    for (const Slice& x : s) all.insert(all.end(), x.pixels.begin(), x.pixels.end());
    io::MemSource ms(all.data(), all.size());
    if (!img::read_voxels(ms, t, img::host_is_big_endian(), dims, lim, out, "the pixel data", err)) return false;
    if (same_rescale) {
        out->scl_slope = s[0].slope;
        out->scl_inter = s[0].intercept;
    } else {
        // Per-slice rescaling: float64 values, slope 1.
        const size_t per = size_t(dims[0]) * size_t(dims[1]);
        std::vector<uint8_t> f(per * n * 8);
        double* o = reinterpret_cast<double*>(f.data());
        for (size_t k = 0; k < n; ++k) {
            const uint8_t* p = s[k].pixels.data();
            const std::string nm = t.name;
            double* q = o + k * per;
            if (nm == "uint8") rescale_into<uint8_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "int8") rescale_into<int8_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "uint16") rescale_into<uint16_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "int16") rescale_into<int16_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "uint32") rescale_into<uint32_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "int32") rescale_into<int32_t>(p, per, s[k].slope, s[k].intercept, q);
            else if (nm == "float32") rescale_into<float>(p, per, s[k].slope, s[k].intercept, q);
            else rescale_into<double>(p, per, s[k].slope, s[k].intercept, q);
        }
        out->data.swap(f);
        out->voxel_type = kNiftiVoxF64;
        out->bytes_per_voxel = 8;
        out->datatype = kNiftiDtFloat64;
        out->scl_slope = 1;
        out->scl_inter = 0;
    }
    // LPS axes: i along the row direction by the column spacing, j along the
    // column direction by the row spacing, k the step between positions.
    const double* ps = s[0].pixel_spacing;  // (row spacing, column spacing)
    const double axis[3][3] = {{iop[0] * ps[1], iop[1] * ps[1], iop[2] * ps[1]},
                               {iop[3] * ps[0], iop[4] * ps[0], iop[5] * ps[0]},
                               {step[0], step[1], step[2]}};
    out->descrip = "DICOM series";
    if (src && !take_source(s, src, err)) return false;
    return img::set_lps_geometry(axis, s[0].ipp, out, "DICOM positions", "ImagePositionPatient / ImageOrientationPatient",
                                 err);
}

}  // namespace

bool dicom_read_series(const std::string& directory, NiftiImage* out, std::string* err, const NiftiLimits& lim,
                       DicomSource* source) {
    if (!out) return fail(err, "dicom_read_series: null output");
    *out = NiftiImage();
    if (source) *source = DicomSource();
    std::string e;
    bool ok = false;
    try {
        ok = read_series(directory, out, &e, lim, source);
    } catch (const std::exception& ex) {
        e = std::string("GDCM failed: ") + ex.what();
    } catch (...) {
        e = "GDCM failed with an unknown exception";
    }
    if (!ok) return fail(err, directory + ": " + e);
    return true;
}

}  // namespace ffseg_tools
