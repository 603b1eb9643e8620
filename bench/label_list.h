// "--labels 73,71,77": the AAL labels a Colin27 benchmark runs.
#pragma once
#include <cstdlib>
#include <vector>

inline void parse_label_list(char* s, std::vector<int>* labels) {
  while (*s) {
    labels->push_back(int(std::strtol(s, &s, 10)));
    if (*s == ',') ++s;
    else if (*s) break;
  }
}
