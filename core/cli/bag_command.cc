// `skidimm bag FILE`: parses nothing more than the path; the report is the
// library's (ros/bag_info.h).
#include <iostream>

#include "commands.h"
#include "skidimm/errors.h"
#include "skidimm/io/ros/bag_info.h"

namespace skidimm {
namespace cli {

int bag_info(const std::filesystem::path& bag) {
  return report_errors("skidimm bag", [&] {
    // A bag's reader seeks (the summary at its end first): it reads files only.
    if (bag == "-") throw UsageError("a bag is read from its file, not from standard input: give its path");
    const ros::BagInfo info = ros::describe_bag(bag);
    std::cout << ros::format_bag_info(info);
    // A bag cut short is described as far as it reads, and reported.
    if (!info.problem.empty()) throw Error(info.problem + " (the report above stops there)");
    return kExitOk;
  });
}

}  // namespace cli
}  // namespace skidimm
