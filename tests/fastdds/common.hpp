// Shared by the Fast DDS peers (peer.cpp, param_peer.cpp): CDR types by hand
// (field order = .msg order; CDR is positional), one TopicDataType for all,
// a loopback-only participant, rmw_fastrtps' default QoS, a JSON string.
#pragma once
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace eprosima::fastdds::dds;
using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::FastBuffer;
using eprosima::fastrtps::rtps::SerializedPayload_t;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using Clock = std::chrono::steady_clock;

// ---- common message parts ----
struct Time {
    int32_t sec = 0;
    uint32_t nanosec = 0;
};
struct Header {
    Time stamp;
    std::string frame_id;
};
static void ser(Cdr& c, const Header& h) { c << h.stamp.sec << h.stamp.nanosec << h.frame_id; }
static void de(Cdr& c, Header& h) { c >> h.stamp.sec >> h.stamp.nanosec >> h.frame_id; }

// One TopicDataType for every message struct (no keys, XCDR1 as ROS 2 uses).
template <class T>
class PlainType : public TopicDataType {
public:
    PlainType() {
        setName(T::type());
        m_typeSize = 1 << 16;
        m_isGetKeyDefined = false;
    }
    bool serialize(void* data, SerializedPayload_t* payload) override {
        FastBuffer fb(reinterpret_cast<char*>(payload->data), payload->max_size);
        Cdr c(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
        payload->encapsulation = c.endianness() == Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
        try {
            c.serialize_encapsulation();
            static_cast<T*>(data)->serialize(c);
        } catch (...) {
            return false;
        }
        payload->length = static_cast<uint32_t>(c.getSerializedDataLength());
        return true;
    }
    bool deserialize(SerializedPayload_t* payload, void* data) override {
        FastBuffer fb(reinterpret_cast<char*>(payload->data), payload->length);
        Cdr c(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
        try {
            c.read_encapsulation();
            static_cast<T*>(data)->deserialize(c);
        } catch (...) {
            return false;
        }
        return true;
    }
    std::function<uint32_t()> getSerializedSizeProvider(void*) override {
        return [] { return uint32_t(1 << 16); };
    }
    void* createData() override { return new T(); }
    void deleteData(void* d) override { delete static_cast<T*>(d); }
    bool getKey(void*, InstanceHandle_t*, bool) override { return false; }
};

static double secs_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}
static void log(const std::string& s) {
    std::printf("[fastdds-peer] %s\n", s.c_str());
    std::fflush(stdout);
}

// A participant on 127.0.0.1 only, discovering by unicast (as the node's --loopback).
static DomainParticipant* make_participant(int domain, const char* name) {
    DomainParticipantQos q = PARTICIPANT_QOS_DEFAULT;
    q.name(name);
    q.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.push_back("127.0.0.1");
    q.transport().user_transports.push_back(udp);
    eprosima::fastrtps::rtps::Locator_t peer;
    eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, 127, 0, 0, 1);
    q.wire_protocol().builtin.initialPeersList.push_back(peer);
    return DomainParticipantFactory::get_instance()->create_participant(domain, q);
}

// rmw_fastrtps' defaults for topics and services: reliable, volatile, keep last 10,
// asynchronous publication.
static DataWriterQos writer_qos(bool transient = false, int depth = 10) {
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = transient ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = depth;
    q.publish_mode().kind = ASYNCHRONOUS_PUBLISH_MODE;
    q.data_sharing().off();
    return q;
}
static DataReaderQos reader_qos(bool transient = false, int depth = 10) {
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = transient ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = depth;
    q.data_sharing().off();
    return q;
}

template <class T>
static Topic* topic(DomainParticipant* p, const char* name) {
    TypeSupport ts(new PlainType<T>());
    ts.register_type(p);
    return p->create_topic(name, T::type(), TOPIC_QOS_DEFAULT);
}

static std::string json_str(const std::string& s) {
    std::string o = "\"";
    for (char ch : s) {
        if (ch == '"' || ch == '\\') o += '\\';
        if (static_cast<unsigned char>(ch) >= 0x20) o += ch;
    }
    return o + "\"";
}

